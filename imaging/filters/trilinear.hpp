#pragma once
/// @file
/// @brief The one trilinear sampler of voxel volumes, with an explicit missing-data policy.

#include "imaging/filters/missing_data.hpp"
#include "imaging/io/volume.hpp"

namespace brainshift::imaging::filters {

/// @brief True when continuous index `ijk` lies on the sampler's grid: within half a voxel
/// beyond the outer voxel centres along every axis (NaN is not on it).
[[nodiscard]] bool on_sampling_grid(const ImageGeometry& geometry, const Vector3d& ijk);

/// @brief Trilinear interpolation of `image` at continuous index `ijk` (voxel centres at
/// integers). Within half a voxel beyond the outer centres the index is clamped onto them (the
/// border value); farther out the position is missing. An axis of one voxel is constant.
/// Exact at voxel centres and for images linear in (i, j, k).
/// Missing data (`missing`): ZERO: 0 beyond the grid, a non-finite voxel counts as 0;
/// CLAMP: beyond the grid the index is clamped onto the grid, a non-finite voxel among the 8
/// neighbours gives a non-finite result; NAN_RESULT: NaN beyond the grid, non-finite voxels as
/// CLAMP; RENORMALISE: NaN beyond the grid, non-finite voxels (and corners of zero weight) are
/// left out and the others' weights renormalised, NaN when less than half the weight is left.
/// @param[in] image  the volume (any number of components).
/// @param[in] ijk  continuous voxel index.
/// @param[in] missing  the missing-data policy.
/// @param[in] component  which component, in [0, image.components).
/// @return the interpolated value (image units).
[[nodiscard]] float sample_trilinear(const VolumeF& image, const Vector3d& ijk, MissingData missing,
                                     int component = 0);

}  // namespace brainshift::imaging::filters
