#pragma once
/// @file
/// @brief Constraint builders of the registration: rows from filtered pairs and
/// from the model's own surface. Positions in mm, world frame of the model.
///   vessels    — sliding on a line: the model's skeleton point nearest to an intra-operative
///                vessel point must lie on the line through that point along the segment
///                (2 rows; free along the vessel, seed 002 §3.4);
///   footprint  — unilateral: the model's surface stays on the tissue side of the probe plane
///                through each footprint point (1 row, n·(p − target) ≥ 0, n into the tissue);
///   dura       — surface vertices outside the craniotomy stay on the rest surface (bilateral
///                sliding plane) or inside it (unilateral: the brain may fall away from the dura
///                but not cross it); the plane is re-paired to the nearest rest triangle each
///                iteration, so sliding is not limited to the tangent plane; the plane's normal
///                is the rest vertex normals interpolated at the closest point (continuous across
///                edges, so a vertex sitting on an edge does not flip between facet normals);
///   landmarks  — bilateral points (3 rows).
/// Fixed (cerebellum-side) nodes are Dirichlet nodes of the mechanical model, not rows.
/// Surfaces are expected oriented outward (counter-clockwise seen from outside), as the
/// boundary faces of a positively oriented tetrahedral mesh are.

#include "constraints/registration/pairing/pairing.hpp"
#include "constraints/rows/constraint_rows.hpp"
#include "core/geometry/skeleton.hpp"
#include "core/mapping/barycentric_mapping.hpp"
#include "core/mesh/tet_mesh.hpp"
#include "core/option_fields.hpp"

#include <vector>

namespace brainshift::constraints {

/// Feature vertices tied to the mesh by a barycentric mapping. Views: mesh and map are not
/// owned and must outlive this object.
struct MappedVertices {
  const core::TetMesh* mesh = nullptr;
  const core::BarycentricMapping* map = nullptr;
  /// Nodes and weights of vertex i (≤ 4 nodes; zero weights dropped).
  [[nodiscard]] Stencil stencil(index_t i) const;
  /// Tetrahedron that vertex i is mapped into.
  [[nodiscard]] index_t tet(index_t i) const { return map->tet()[static_cast<std::size_t>(i)]; }
};

/// Dura contact outside the craniotomy.
struct DuraOptions {
  enum class Mode { NONE, SLIDING, UNILATERAL };
  Mode mode = Mode::NONE;
  Vector3d craniotomy_centre = Vector3d::Zero();  ///< mm, world; on or near the surface
  double craniotomy_radius_mm = 0.0;  ///< vertices nearer than this (rest) to the centre are free
  double max_distance_mm = 10.0;  ///< no row for a vertex farther than this from the rest surface
  /// Empty when valid, else what is wrong.
  [[nodiscard]] std::string validate() const;
};
std::string to_string(DuraOptions::Mode mode);
/// Names of DuraOptions::Mode in the scene, reports and the command line.
constexpr std::array<core::EnumName<DuraOptions::Mode>, 3> enum_names(DuraOptions::Mode /*tag*/) {
  return {{{DuraOptions::Mode::NONE, "none"},
           {DuraOptions::Mode::SLIDING, "sliding"},
           {DuraOptions::Mode::UNILATERAL, "unilateral"}}};
}

/// The options' names, ranges and documentation (core/option_fields.hpp). Names are scene paths:
/// the mode is constraints.dura, the craniotomy its own object.
template <class V>
void visit_fields(DuraOptions& o, V&& v) {
  v("constraints.dura", o.mode, "contact with the dura outside the craniotomy");
  v("constraints.dura_max_distance_mm", o.max_distance_mm, core::Range{1e-6, 1000},
    "no dura row for a surface vertex farther than this from the rest surface (mm)");
  v("craniotomy.centre_mm", o.craniotomy_centre, "centre of the craniotomy (mm, world RAS)");
  v("craniotomy.radius_mm", o.craniotomy_radius_mm, core::Range{0, 500},
    "surface vertices nearer than this to the centre are free of the dura (mm)");
}

/// Sliding-line rows for vessel pairs (`pairs` from segments of `skeleton`, points from `points`).
void add_vessel_rows(ConstraintRows& rows, const std::vector<Pair>& pairs,
                     const core::Skeleton& skeleton, const MappedVertices& mapped,
                     ConstRef<MatrixX3d> x, ConstRef<MatrixX3d> points);

/// Unilateral rows for footprint pairs (`pairs` from triangles of `surface`). `normals`: #P×3 unit
/// normals into the tissue per footprint point, or empty to use the paired triangle's inward
/// normal.
void add_footprint_rows(ConstraintRows& rows, const std::vector<Pair>& pairs,
                        const core::SurfaceMesh& surface, const MappedVertices& mapped,
                        ConstRef<MatrixX3d> x, ConstRef<MatrixX3d> points,
                        ConstRef<MatrixX3d> normals);

/// Area-weighted unit vertex normals of a surface (#V×3; zero for unused vertices).
MatrixX3d vertex_normals(const core::SurfaceMesh& surface);

/// Dura rows for the vertices of `surface` outside the craniotomy, each against its nearest
/// triangle of the rest surface (`rest_index`, built on the same surface at rest, whose vertex
/// normals are `rest_normals`). Vertices in `skip` (e.g. those carrying a footprint row) get
/// none. Returns the number of rows added.
index_t add_dura_rows(ConstraintRows& rows, const DuraOptions& options,
                      const core::SurfaceMesh& surface, const FeatureIndex& rest_index,
                      ConstRef<MatrixX3d> rest_normals, const MappedVertices& mapped,
                      ConstRef<MatrixX3d> x, const std::vector<bool>& skip = {});

/// Bilateral point rows: the model points (rest positions, mapped by `mapped`) go to `targets`.
void add_landmark_rows(ConstraintRows& rows, const MappedVertices& mapped, ConstRef<MatrixX3d> x,
                       ConstRef<MatrixX3d> targets);

}  // namespace brainshift::constraints
