#pragma once
/// @file
/// @brief The start's bulk search, used when the pose is known (a pre-dura sweep's pose, or the
/// identity with start = identity; start_at_pose() in global_start.hpp): the bulk shift of the
/// intra-operative vessel points relative to the pre-operative skeleton, the shift s (mm) that
/// maximises the kernel correlation
///   score(s) = Σᵢ κ(d(pᵢ − s)),   κ(d) = max(0, 1 − d²/τ²),
/// with d(q) the distance from q to the nearest skeleton segment, searched exhaustively on a grid
/// of translations |sₖ| ≤ radius (then refined with a smaller τ around the best).
///
/// Why: brain shift (5–20 mm) is larger than the spacing of cortical vessels (1–3 mm), so the
/// nearest-feature pairing of ICP starting from the rest shape picks the neighbouring vessel and
/// the loop settles in a wrong local minimum. A rigid ICP from the identity slides along the
/// cortical sheet for the same reason. An exhaustive search over translations has no basin to
/// fall out of; the truncated kernel ignores spurious Doppler blobs and vessels missing on either
/// side (kernel correlation: Tsin & Kanade, ECCV 2004). A translation is the lowest-frequency
/// part of the shift; the deformation that remains is left to the constrained ICP, which starts
/// from pairs made at the shifted positions.
///
/// The distances are tabulated once on a voxel grid (truncated at τ, exact point-to-segment
/// distances near each segment), so one candidate costs one lookup per point.

#include "constraints/registration/start/start_result.hpp"
#include "core/config.hpp"
#include "core/geometry/skeleton.hpp"
#include "core/option_fields.hpp"

#include <string>
#include <vector>

namespace brainshift::constraints {

struct BulkSearchOptions {
  bool enabled = true;
  double radius_mm = 20.0;      ///< largest shift searched, per axis (mm)
  double coarse_step_mm = 1.0;  ///< grid of candidate shifts (mm)
  /// τ of the coarse search (mm): ≥ the step so no peak falls between nodes. Wide: the
  /// Doppler and MRA centrelines of one vessel are 1–2 mm apart even at the true shift, and a
  /// single shift is off by 1–3 mm at the edges of the field of view.
  double coarse_kernel_mm = 3.0;
  double fine_kernel_mm = 3.0;  ///< τ of the refinement on a quarter-step grid (mm)
  double voxel_mm = 0.5;        ///< distance table spacing (mm)
  /// At most this many points are scored (an even subsample): clutter-heavy Doppler volumes
  /// give tens of thousands of centreline points and the shift needs far fewer.
  int max_points = 2000;
  /// Keep the shift only when its score beats the score at zero shift by this factor; a flat
  /// score (a single straight vessel, too few points) says nothing about the shift.
  double min_gain = 1.2;
  /// Empty when valid, else what is wrong.
  [[nodiscard]] std::string validate() const;
};

/// The options' names, ranges and documentation (core/option_fields.hpp); in the scene under
/// shift_search (GlobalStartOptions::bulk_search; the keys kept their names). The grid and kernel
/// settings are not scene keys (constants of the method).
template <class V>
void visit_fields(BulkSearchOptions& o, V&& v) {
  v("enabled", o.enabled,
    "search the bulk shift when the pose is known (a pre-dura pose, or start identity)");
  v("radius_mm", o.radius_mm, core::Range{0, 200}, "largest shift searched, per axis (mm)");
}

/// Searches the bulk shift of `points` (#N×3, mm) relative to the segments of `skeleton` (mm,
/// same frame). `basis` (empty, or one 3×3 matrix per point) shapes the shift: point i is
/// compared at pᵢ − basisᵢ·s instead of pᵢ − s, so that s is the shift of a smooth deformation
/// (e.g. the model's response to a uniform load, normalised to I on average over the points)
/// rather than a translation. No points or segments: not accepted, zero shift.
/// \throws brainshift::Error when options.validate() fails, the inputs are not finite or the
/// basis has the wrong size.
/// @return the bulk part of a StartResult: bulk_shift (p_intra ≈ p_pre + basis·shift; zero when
/// not accepted), bulk_accepted, score (fine score at the shift), score_identity (at zero) and
/// bulk_message; the pose part is left at its defaults.
StartResult search_bulk_shift(const core::Skeleton& skeleton, ConstRef<MatrixX3d> points,
                              const std::vector<Matrix3d>& basis, const BulkSearchOptions& options);

namespace detail {

class DistanceGrid;

/// The bulk search's coarse scores: for every shift s = step · (x − k, y − k, z − k) of the
/// (2k + 1)³ grid (x fastest, then y, then z), Σ_j max(0, 1 − table.nearest(p_j − B_j s) / τ²)
/// over the points p_j = points.row(j · stride) (B_j their basis rows, I without a basis), summed
/// in the order of j. On the idle cores, a z-plane of shifts at a time and point by point within
/// it; a moved point beyond τ (DistanceGrid::nearest_within_tau()) adds exactly +0 and is skipped,
/// so each sum is the one a plain loop over the points makes, to the bit. `table` must be built
/// with `tau`.
std::vector<double> coarse_shift_scores(const DistanceGrid& table, ConstRef<MatrixX3d> points,
                                        const std::vector<Matrix3d>& basis, Eigen::Index stride,
                                        int k, double step, double tau);

/// T · p for every row of p (#N×3, mm).
MatrixX3d transformed(const Eigen::Isometry3d& T, ConstRef<MatrixX3d> p);

/// The segments of `s` with both ends within the bounding box of `points` enlarged by `margin`
/// (mm): the part of the pre-operative tree the probe can have seen; all of `s` when none is.
core::Skeleton skeleton_near(const core::Skeleton& s, ConstRef<MatrixX3d> points, double margin);

}  // namespace detail

}  // namespace brainshift::constraints
