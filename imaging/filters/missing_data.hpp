#pragma once
/// @file
/// @brief The policy of the imaging filters and samplers for data they do not have: positions
/// outside the voxel grid and non-finite (NaN, ±∞) voxels.

namespace brainshift::imaging::filters {

/// What a sampler or a filter does with a missing sample: a position beyond the grid, or a
/// non-finite voxel. Each function that takes it says where "beyond the grid" begins.
enum class MissingData {
  ZERO,         ///< a missing sample counts as 0
  CLAMP,        ///< beyond the grid: the nearest voxel of the grid (the face value repeated);
                ///< non-finite voxels propagate by IEEE arithmetic
  NAN_RESULT,   ///< beyond the grid: NaN; non-finite voxels propagate by IEEE arithmetic
  RENORMALISE,  ///< missing samples are left out and the weights of the others renormalised;
                ///< NaN when less than half of the weight is on samples that exist
};

}  // namespace brainshift::imaging::filters
