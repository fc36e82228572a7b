#pragma once
/// @file
/// @brief The phantom's own fine tetrahedral mesh for the truth solver, independent of any
/// registration mesh: a voxel mesh of cubes of edge h aligned with the world axes (the bottom
/// layer of nodes lies exactly on the flattened base), each cube split into five tetrahedra
/// (alternating by parity so that neighbouring cubes share face diagonals), kept when the cube
/// centre is inside the brain. Boundary nodes are optionally snapped onto the analytic brain
/// ellipsoid (closest point; base nodes and nodes just above the base only horizontally, and
/// only from outside, so the base stays flat); while a tetrahedron is thinner than a set fraction of its unsnapped
/// volume, the largest snap among its nodes is undone (at h = 4 mm about 70 % of the boundary
/// nodes end on the ellipsoid; the others, at re-entrant stair corners, stay within √3/2·h of it).
/// Base-rim nodes whose snap is undone may stick out of the brain ellipsoid (and the skull) by
/// up to √3/2·h; they are the fixed skull-base nodes of the sag case, so they never move.
///
/// Materials by the label at each tetrahedron's centroid: brain, tumour, and the ventricles
/// modelled as a very soft solid (a fluid-filled cavity that keeps its volume: nu as the brain,
/// E a tenth of the brain's by default) rather than holes, so the mesh stays simply connected and
/// the CSF inside cannot collapse.

#include <cstdint>
#include <string>
#include <vector>

#include "core/mesh/tet_mesh.hpp"
#include "core/units.hpp"
#include "data_synth/geometry/brain_phantom.hpp"

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
PhantomMesh make_phantom_mesh(const PhantomGeometry& geometry, const PhantomMeshOptions& options = {});

}  // namespace brainshift::data_synth
