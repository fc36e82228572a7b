#pragma once
/// @file
/// @brief The defaults `prepare` derives from the geometry when the scene does not give them: the
/// fixed region (the part of the brain on the skull base: brain stem, cerebellum and the
/// inferior temporal and frontal lobes on a real brain, the flattened base and its rim on the
/// phantoms) and the craniotomy (over the tumour when there is one, else at the top of the
/// brain). Each comes with a one-line statement of the rule, for the
/// model's manifest. Positions in mm, world RAS frame (S up).

#include "core/geometry/skeleton.hpp"
#include "core/mesh/tet_mesh.hpp"
#include "imaging/meshing/boundary_surface.hpp"

#include <cstdint>
#include <string>
#include <vector>

namespace brainshift::imaging {

/// The default fixed region and the rule that chose it.
struct FixedRegion {
  std::vector<index_t> nodes;          ///< tet-mesh nodes, increasing
  Vector3d down = Vector3d(0, 0, -1);  ///< unit caudal direction used
  double extent_mm = 0.0;              ///< the boundary's extent along `down`, mm
  double height_mm = 0.0;              ///< slab height above the lowest point, mm
  std::string rule;                    ///< one line, for the manifest
};

/// Share of the brain's extent along `down` that default_fixed_region() fixes: the part that
/// rests on the skull base. On ICBM152 (152.8 mm from the brain stem's cut end at z = −70 mm to
/// the vertex) 30 % reaches z ≈ −25 mm: the brain stem, the cerebellum in the posterior fossa,
/// the inferior temporal lobes in the middle fossa (from z = −50 mm) and the lowest
/// orbito-frontal cortex on the anterior fossa's floor (from z = −30 mm); on the 93 mm phantoms
/// 28 mm. Why not the brain stem and lower cerebellum alone (16 %, the rule before 2026-12-07): a
/// model held only there has its frontal and temporal lobes hanging free, so its response to the
/// sag's load moves the deep brain with the cortex, where the skull's floor holds it. ICBM152
/// with a pre-dura pose (the phantom's truth: its own mesh and solver, skull contact) over the
/// whole brain 6.75 → 3.26 mm, and 7.86 → 4.07 mm more than 60 mm from the vessels, where no
/// registration is 5.53 mm (docs/BENCHMARKS.md, "The fixed base on the skull's floor").
inline constexpr double kFixedBaseFraction = 0.30;

/// The lowest slab of the brain: the outer-boundary nodes within h of the lowest point along
/// `down`, h = max(min_height_mm, fraction · extent) (kFixedBaseFraction: the brain's part on the
/// skull base).
/// @param[in] outer          outer_boundary_surface() of the mesh.
/// @param[in] down           caudal direction, world; need not be unit, ≠ 0.
/// @param[in] fraction       of the extent along `down`, in [0, 1].
/// @param[in] min_height_mm  mm, ≥ 0.
/// \throws brainshift::Error on a zero direction or out-of-range fraction or height.
FixedRegion default_fixed_region(const MeshSurface& outer,
                                 const Vector3d& down = Vector3d(0, 0, -1),
                                 double fraction = kFixedBaseFraction, double min_height_mm = 15.0);

/// The default craniotomy and the rule that chose it.
struct Craniotomy {
  Vector3d centre = Vector3d::Zero();  ///< on the collision surface, mm
  double radius_mm = 30.0;             ///< mm
  std::string rule;                    ///< one line, for the manifest
};

/// Over the tumour when the mesh has one (tetrahedra labelled 2): the collision-surface vertex
/// nearest the tumour's centroid (the shortest way in); else the highest vertex (largest S).
/// @param[in] surface    collision surface, mm (≥ 1 vertex).
/// @param[in] mesh       tetrahedral mesh, mm.
/// @param[in] tet_label  #T labels (1 brain, 2 tumour, 3 ventricles), or empty.
/// @param[in] radius_mm  craniotomy radius, mm, > 0.
/// \throws brainshift::Error when the surface has no vertex, the labels do not match the mesh, or
/// the radius is not positive.
Craniotomy default_craniotomy(const core::SurfaceMesh& surface, const core::TetMesh& mesh,
                              const std::vector<std::uint8_t>& tet_label, double radius_mm = 30.0);

}  // namespace brainshift::imaging
