#pragma once
/// @file
/// @brief 3-D topological thinning of a binary voxel mask to one-voxel-thin curves (a curve
/// skeleton), for vessel centrelines.
///
/// Directional parallel thinning in the manner of T.-C. Lee, R. L. Kashyap, C.-N. Chu,
/// "Building skeleton models via 3-D medial surface/axis thinning algorithms", CVGIP 56(6), 1994:
/// six sub-iterations (border points facing +x, −x, +y, −y, +z, −z); in each, the border points
/// that are simple and not curve end points are collected, then deleted one by one after
/// checking again that they are still simple (so topology is preserved exactly). A point is
/// simple for (26, 6) connectivity when its 26-neighbourhood minus itself has one 26-connected
/// foreground component and its 18-neighbourhood has one 6-connected background component
/// 6-adjacent to it (G. Bertrand, G. Malandain, Pattern Recognition Letters 15, 1994); this is
/// the exact test that Lee et al. evaluate with the Euler table and octree labelling. End point:
/// exactly one 26-neighbour.

#include "imaging/io/volume.hpp"

#include <cstdint>

namespace brainshift::imaging {

/// Summary of a thinning run.
struct ThinningReport {
  int iterations = 0;          ///< full passes over the six directions
  std::int64_t removed = 0;    ///< voxels deleted
  std::int64_t remaining = 0;  ///< skeleton voxels
};

/// Thins `mask` in place (non-zero = foreground → 1, else 0) to 26-connected curves; each
/// 26-connected component keeps its number of tunnels and cavities. Only the foreground's
/// bounding box is visited, so the cost is proportional to the foreground, not the grid.
/// @param[in,out] mask  one component.
ThinningReport thin_to_curves(Volume<std::uint8_t>& mask);

}  // namespace brainshift::imaging
