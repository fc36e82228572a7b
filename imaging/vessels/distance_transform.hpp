#pragma once
/// @file
/// @brief Exact Euclidean distance transform of a binary voxel mask, in millimetres, with
/// anisotropic spacing: separable lower-envelope-of-parabolas passes along i, j, k
/// (P. Felzenszwalb, D. Huttenlocher, "Distance Transforms of Sampled Functions", Theory of
/// Computing 8, 2012). Linear in the number of voxels.

#include "imaging/io/volume.hpp"

#include <cstdint>

namespace brainshift::imaging {

/// For every voxel, the distance (mm) from its centre to the nearest background voxel centre;
/// 0 on background. Voxels outside the grid count as background, so a foreground voxel on the
/// grid's face is one spacing from the background.
/// @param[in] mask  one component; non-zero = foreground. Only `geometry.size` and
/// `geometry.spacing` are used (distances are measured in the index frame scaled by spacing,
/// which equals the world distance for an orthonormal direction).
/// @return a one-component volume on the same grid, mm.
VolumeF distance_to_background(const Volume<std::uint8_t>& mask);

}  // namespace brainshift::imaging
