#pragma once
/// @file
/// @brief Blocks of the vessel skeleton for cross-validation: each segment labelled with its
/// branch (a maximal chain of segments between skeleton points whose degree is not 2), branches
/// optionally cut into pieces of at most a given arc length. The noise model (noise_model.hpp)
/// holds out all the vessel rows paired with one block together, because the Doppler
/// centrelines' errors are correlated along a vessel: holding out one point at a time lets its
/// neighbours (which share its error) predict it, and the error is read as signal.
/// Lengths in mm, positions in the skeleton's frame.

#include "core/geometry/skeleton.hpp"

#include <vector>

namespace brainshift::constraints {

/// Block id of every segment of `skeleton` (same order as skeleton.segments; ids 0..B-1).
/// @param[in] max_length_mm a branch longer than this is cut into consecutive pieces of at most
/// about this arc length (mm); 0 keeps whole branches. A cycle (no end or junction) is one branch.
std::vector<index_t> segment_blocks(const core::Skeleton& skeleton, double max_length_mm = 0.0);

}  // namespace brainshift::constraints
