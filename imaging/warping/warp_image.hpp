#pragma once
/// @file
/// @brief Images and displacement fields (forward and inverse) through the piecewise-linear map
/// of a deformed tetrahedral mesh.
///
/// The mesh defines φ(X) = X + u(X) (rest X → deformed x, world RAS mm), linear on every
/// tetrahedron: a point with barycentric coordinates λ in the deformed tetrahedron comes from the
/// point with the same λ in the rest tetrahedron. Outside the mesh the map is the rigid part T
/// only (a 4×4 homogeneous rigid transform, rest → deformed world, identity by default).
///
/// All three rasterise each tetrahedron over its bounding box in the output grid's index
/// space: per voxel row the barycentric coordinates are linear in i, so the row's inside span is
/// solved for directly and the mapped quantity is updated incrementally. Work is split over
/// threads by slabs of output planes k, so no voxel is written by two threads. A voxel centre on
/// a face shared by two tetrahedra is written by both, with the same value up to rounding
/// (the map is continuous). Where deformed tetrahedra overlap (an inverted element), the last one
/// written wins; degenerate (flat) deformed tetrahedra are skipped.

#include "core/config.hpp"
#include "core/mesh/tet_mesh.hpp"
#include "imaging/io/volume.hpp"

#include <optional>

namespace brainshift::imaging {

/// Options of warp_image().
struct WarpOptions {
  /// Grid of the warped image; std::nullopt: the input image's geometry.
  std::optional<ImageGeometry> output_geometry;
  /// Rigid rest → deformed world transform (4×4, rotation + translation, mm) applied outside the
  /// deformed mesh: there output(y) = input(T⁻¹ y). Identity: the image is left as it is.
  Eigen::Matrix4d rigid = Eigen::Matrix4d::Identity();
  /// Value of output voxels whose pre-image lies outside the input image (more than half a voxel
  /// beyond its outermost voxel centres).
  float outside_value = 0.0F;
  /// Worker threads (≥ 1).
  int threads = 2;
};

/// Pulls the pre-operative image back through the deformation: output(y) = input(φ⁻¹(y)).
/// For each output voxel centre y inside a deformed tetrahedron, X = Σ λ_a X_a with λ the
/// barycentric coordinates of y in the deformed tetrahedron (x_a = X_a + u_a); elsewhere
/// X = T⁻¹ y. The input is sampled trilinearly at X (world → index with the full direction
/// matrix; within half a voxel beyond the outer voxel centres the nearest border value is used).
/// @param[in] image         scalar volume (one component), e.g. the pre-operative MRI.
/// @param[in] mesh          rest mesh, world RAS mm (rest = the frame of `image`).
/// @param[in] displacement  #N×3 nodal displacement u, mm, world frame.
/// @param[in] options       output grid, rigid part outside the mesh, threads.
/// @return the warped image on the output grid.
/// \throws brainshift::Error when the image is empty or has several components, the
/// displacement has the wrong shape or is not finite, or options.rigid is not a rigid transform.
VolumeF warp_image(const VolumeF& image, const core::TetMesh& mesh,
                   ConstRef<MatrixX3d> displacement, const WarpOptions& options = {});

/// Options of displacement_field() and inverse_displacement_field().
struct DisplacementFieldOptions {
  /// Rigid rest → deformed transform T (4×4, mm); outside the mesh the field is its rigid part.
  Eigen::Matrix4d rigid = Eigen::Matrix4d::Identity();
  /// Voxel centres outside the mesh but within this distance (mm, ≥ 0) of a tetrahedron's face
  /// planes take that tetrahedron's affine map extended (the tetrahedron they are least outside
  /// of), not the rigid part. 0: exactly the mesh's map inside, the rigid part outside. With
  /// trilinear_support_mm() of the grid, trilinear interpolation of the field anywhere inside
  /// the mesh blends only values of the mesh's map (none of the rigid part across the boundary).
  double extension_mm = 0.0;
  int threads = 2;  ///< worker threads (≥ 1)
};

/// The forward displacement u(X) = φ(X) − X sampled at the voxel centres X of a rest-space grid:
/// Σ λ_a u_a inside the rest mesh (λ: barycentric coordinates of X in the rest tetrahedron),
/// T X − X outside.
/// @param[in] mesh          rest mesh, world RAS mm.
/// @param[in] displacement  #N×3 nodal displacement, mm, world frame.
/// @param[in] geometry      the grid to sample on (rest space).
/// @return a 3-component volume (u_R, u_A, u_S per voxel, mm, world RAS).
/// \throws brainshift::Error as warp_image(), or for an empty geometry or a negative extension.
VolumeF displacement_field(const core::TetMesh& mesh, ConstRef<MatrixX3d> displacement,
                           const ImageGeometry& geometry,
                           const DisplacementFieldOptions& options = {});

/// The forward field twice from one rasterisation: without and with the extension.
struct ForwardDisplacementFields {
  VolumeF exact;     ///< displacement_field() with extension_mm = 0 (the mesh's map, rigid outside)
  VolumeF extended;  ///< displacement_field() with the options' extension_mm
};

/// displacement_field() without and with `options.extension_mm`, computed in one pass (the
/// tetrahedra are rasterised once; the extension is then added to a copy). Both are equal,
/// voxel for voxel, to the two separate displacement_field() calls.
/// \throws brainshift::Error as displacement_field().
ForwardDisplacementFields displacement_fields(const core::TetMesh& mesh,
                                              ConstRef<MatrixX3d> displacement,
                                              const ImageGeometry& geometry,
                                              const DisplacementFieldOptions& options);

/// The inverse displacement v(y) = φ⁻¹(y) − y sampled at the voxel centres y of a grid in the
/// deformed space: y + v(y) is the rest point now at y. Inside a deformed tetrahedron it is exact
/// (rasterised like warp_image(): Σ λ_a (X_a − x_a) = −Σ λ_a u_a with λ the barycentric
/// coordinates of y in the deformed tetrahedron); outside, T⁻¹ y − y. This is the field that
/// resamples rest-space content into the deformed space (ITK's sense of a displacement field).
/// @param[in] mesh          rest mesh, world RAS mm.
/// @param[in] displacement  #N×3 nodal displacement u, mm, world frame.
/// @param[in] geometry      the grid to sample on (deformed space), e.g. covering_grid().
/// @param[in] options       rigid part T, extension beyond the deformed mesh, threads.
/// @return a 3-component volume (v_R, v_A, v_S per voxel, mm, world RAS).
/// \throws brainshift::Error as displacement_field().
VolumeF inverse_displacement_field(const core::TetMesh& mesh, ConstRef<MatrixX3d> displacement,
                                   const ImageGeometry& geometry,
                                   const DisplacementFieldOptions& options = {});

/// The distance (mm) from any point to the farthest of the 8 voxel centres that trilinear
/// interpolation blends there: the voxel diagonal |spacing|.
double trilinear_support_mm(const ImageGeometry& geometry);

/// A grid with the spacing and direction of `like`, its voxel centres aligned with like's, that
/// covers `points` (world mm, #P×3) plus `margin_mm` along every axis.
/// \throws brainshift::Error for no or non-finite points, a negative margin, or a grid of more
/// than 2·10⁹ voxels.
ImageGeometry covering_grid(const ImageGeometry& like, ConstRef<MatrixX3d> points,
                            double margin_mm);

/// Trilinear sample of component `component` (0 … components − 1) of a volume at continuous index
/// (i, j, k) (voxel centres at integers); the border value within half a voxel beyond the outer
/// centres, `outside_value` farther out.
/// Exact at voxel centres and for images linear in (i, j, k).
float sample_trilinear(const VolumeF& image, const Vector3d& ijk, float outside_value = 0.0F,
                       int component = 0);

}  // namespace brainshift::imaging
