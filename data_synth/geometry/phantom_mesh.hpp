#pragma once
/// @file
/// @brief The phantom's own fine tetrahedral mesh for the truth solver, independent of any
/// registration mesh: a voxel mesh of cubes of edge h aligned with the world axes (the bottom
/// layer of nodes lies exactly on the flattened base), each cube split into five tetrahedra
/// (alternating by parity so that neighbouring cubes share face diagonals), kept when the cube
/// centre is inside the brain. Boundary nodes are optionally snapped onto the analytic brain
/// ellipsoid (closest point; base nodes and nodes just above the base only horizontally, and
/// only from outside, so the base stays flat); while a tetrahedron is thinner than a set fraction
/// of its unsnapped volume, the largest snap among its nodes is undone (at h = 4 mm about 70 % of
/// the boundary nodes end on the ellipsoid; the others, at re-entrant stair corners, stay within
/// √3/2·h of it). Base-rim nodes whose snap is undone may stick out of the brain ellipsoid (and the
/// skull) by up to √3/2·h; they are the fixed skull-base nodes of the sag case, so they never move.
///
/// Materials by the label at each tetrahedron's centroid: brain, tumour, and the ventricles
/// modelled as a very soft solid (a fluid-filled cavity that keeps its volume: nu as the brain,
/// E a tenth of the brain's by default) rather than holes, so the mesh stays simply connected and
/// the CSF inside cannot collapse.

#include "core/mesh/tet_mesh.hpp"
#include "core/units.hpp"
#include "data_synth/geometry/brain_phantom.hpp"

#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace brainshift::data_synth {

struct PhantomMeshOptions {
  double cell_size = 4.0;  ///< cube edge h, mm, > 0
  bool snap_to_surface = true;
  /// Smallest allowed snapped volume, as a fraction of the unsnapped tetrahedron's, in (0, 1).
  double min_snapped_volume_fraction = 0.25;
  double brain_youngs_modulus = units::brain_youngs_modulus;    ///< kPa
  double tumour_youngs_modulus = units::tumour_youngs_modulus;  ///< kPa
  double ventricle_youngs_modulus = 0.15;                       ///< kPa (CSF-filled: very soft)
  double poisson_ratio = units::default_poisson_ratio;          ///< all labels
  /// Empty when valid, else the reason.
  [[nodiscard]] std::string validate() const;
};

/// The truth mesh with its labels and boundary node sets.
struct PhantomMesh {
  core::TetMesh mesh;                    ///< validated (core::validate)
  std::vector<std::uint8_t> tet_labels;  ///< #T imaging::Label of each tetrahedron
  std::vector<index_t> base_nodes;       ///< nodes on the flattened base plane (sorted)
  std::vector<index_t> surface_nodes;    ///< other boundary nodes: contact candidates (sorted)
  index_t snapped_nodes = 0;             ///< boundary nodes moved onto the brain ellipsoid
};

/// Builds the mesh. \throws brainshift::Error on invalid geometry or options, or when the mesh
/// would be empty (cell size larger than the brain).
PhantomMesh make_phantom_mesh(const PhantomGeometry& geometry,
                              const PhantomMeshOptions& options = {});

// --- building blocks of voxel truth meshes (also used by label_anatomy.hpp) ------------------

/// Cubes of edge h on the grid origin + h·(i, j, k), 0 ≤ (i, j, k) < cells, kept where
/// inside(cube centre), each split into five positively oriented tetrahedra.
struct CubeTets {
  MatrixX3d nodes;  ///< #N×3 grid positions of the kept cubes' corners, mm
  std::vector<std::array<index_t, 4>> tets;  ///< #T
  std::vector<Eigen::Vector3i> ijk;          ///< #N grid index of each node
  std::vector<char> boundary;  ///< #N 1 on a face of a kept cube with no kept neighbour
};
CubeTets make_cube_tets(const Vector3d& origin, double h, const Eigen::Vector3i& cells,
                        const std::function<bool(const Vector3d&)>& inside);

/// While a tetrahedron of `nodes` is thinner than min_fraction of its `rest` volume, undoes the
/// largest snap among its nodes (`snapped` flags, updated).
void undo_flattening_snaps(const MatrixX3d& rest, const std::vector<std::array<index_t, 4>>& tets,
                           double min_fraction, MatrixX3d& nodes, std::vector<char>& snapped);

/// Labels and materials by the label at each tetrahedron's centroid (background → brain); sets
/// out.mesh (validated) and out.tet_labels.
void assign_materials(MatrixX3d nodes, const std::vector<std::array<index_t, 4>>& tets,
                      const std::function<imaging::Label(const Vector3d&)>& label_at,
                      const PhantomMeshOptions& options, PhantomMesh& out);

}  // namespace brainshift::data_synth
