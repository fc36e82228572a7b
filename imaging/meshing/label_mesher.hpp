#pragma once
/// @file
/// @brief Tetrahedral meshing of a label volume (0 background, 1 brain, 2 tumour, 3 ventricles)
/// with CGAL Mesh_3 (Delaunay refinement of a labeled image domain; Jamin et al., "CGALmesh: a
/// generic framework for Delaunay mesh generation", ACM TOMS 41(4), 2015), followed by sliver
/// exudation. Each sub-domain becomes a material: brain 1.5 kPa, tumour 10 kPa, ventricles either
/// a very soft material (0.5 kPa, default) or a cavity left out of the mesh.
///
/// Frames: CGAL meshes in the "scaled index" space q = diag(spacing) · (i, j, k) (its Image_3 has
/// a spacing and a translation but no direction); every node is mapped afterwards to world RAS mm
/// with the full geometry, p = origin + direction · q, and elements are re-oriented positively
/// (a direction with det = −1, e.g. LPS → RAS flips, would otherwise invert them).
///
/// Initialisation: CGAL's default initial points (rays from the centre) can miss inner structures
/// (an off-centre tumour, the ventricles), so every label interface is also seeded along grid
/// lines 2 × facet_size apart.
///
/// Determinism: the domain's random generator and CGAL's default generator are seeded from
/// MeshingOptions::seed, perturbation, Lloyd and ODT are off and meshing is sequential; with
/// `exude` off the same input and options give the same mesh. \note CGAL 5.5's sliver
/// exudation can choose differently among equivalent weight changes from one call to the next
/// in the same process (the choice depends on memory addresses): with `exude` on (the default)
/// a few nodes and tetrahedra may differ between calls.

#include "core/mesh/tet_mesh.hpp"
#include "imaging/io/volume.hpp"

#include <cstdint>
#include <string>
#include <vector>

namespace brainshift::imaging {

/// What the ventricles (label 3) become.
enum class VentricleModel {
  SOFT_MATERIAL,  ///< meshed, with MeshingOptions::ventricle_youngs_modulus (CSF-filled, nearly
                  ///< free)
  CAVITY,  ///< left out: a hole whose wall (resolved as a sub-domain interface) is mesh boundary
};

/// Sizing, materials and determinism of mesh_labels(). Lengths in mm, moduli in kPa.
struct MeshingOptions {
  double cell_size = 11.0;              ///< upper bound on tetrahedron circumradius, mm
  double cell_radius_edge_ratio = 3.0;  ///< upper bound on circumradius / shortest edge (≥ 2)
  double facet_size = 9.0;              ///< upper bound on surface Delaunay-ball radius, mm
  double facet_distance = 1.5;          ///< upper bound on facet-centre to surface distance, mm
  double facet_angle_deg = 25.0;  ///< lower bound on surface triangle angles, degrees (≤ 30)
  bool exude = true;              ///< sliver exudation (no time limit, deterministic)
  VentricleModel ventricles = VentricleModel::SOFT_MATERIAL;
  double brain_youngs_modulus = 1.5;      ///< kPa
  double tumour_youngs_modulus = 10.0;    ///< kPa
  double ventricle_youngs_modulus = 0.5;  ///< kPa, SOFT_MATERIAL only
  double poisson_ratio = 0.45;            ///< all materials
  unsigned int seed = 0;                  ///< random generator seed (initial surface points)

  /// ≈2k nodes for a brain-sized (≈140 × 170 × 120 mm) volume: the intra-operative default.
  static MeshingOptions coarse();
  /// The coarse sizes divided by `refinement` (> 0); node count grows ≈ refinement³.
  /// Measured on a 140 × 170 × 120 mm ellipsoid: refinement 3 → 28.6k nodes (6 s), 2.5 → 18k.
  static MeshingOptions refined(double refinement);
  /// Empty when valid, else one line naming the first bad field and its value.
  [[nodiscard]] std::string validate() const;
};

/// A mesh of a label volume.
struct MeshingResult {
  core::TetMesh mesh;                   ///< world RAS mm, positively oriented, no unused node
  std::vector<std::uint8_t> tet_label;  ///< #T label (1, 2 or 3) of the sub-domain of each tet
  core::QualityReport quality;          ///< core::quality_report() of `mesh`
  double seconds = 0.0;                 ///< wall-clock time of the whole call, s
};

/// Meshes the non-background labels of `labels`.
/// @param[in] labels   label volume (one component), world geometry with an orthonormal
///                     direction; labels may touch the volume's border (it is padded).
/// @param[in] options  sizing and materials; see MeshingOptions.
/// @return the mesh, validated with core::validate(), with E and ν per tetrahedron from its
/// sub-domain's label.
/// \throws brainshift::Error when the options are invalid, the volume is empty or multi-component,
/// its direction is not orthonormal, a voxel has a label other than 0–3 (the message names the
/// value, the voxel and how many voxels have it), no voxel is labelled, or the structures are
/// too small for the sizes (the mesh comes out empty).
MeshingResult mesh_labels(const LabelVolume& labels,
                          const MeshingOptions& options = MeshingOptions::coarse());

}  // namespace brainshift::imaging
