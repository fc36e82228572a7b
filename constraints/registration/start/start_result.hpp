#pragma once
/// @file
/// @brief The outcome of the registration's start (StartResult): the rigid pose that maps the
/// tracked intra-operative frame into the model, the bulk shift of the model's load response,
/// and the evidence for both. Positions in mm, world (RAS) frame; angles in degrees.

#include "core/config.hpp"

#include <string>

namespace brainshift::constraints {

/// The start's result, the one type every start produces (global_start(), start_at_pose(),
/// search_bulk_shift(), pre_dura_pose(), a warm start's copy): the pose, the bulk shift, and the
/// evidence for each. Every number is finite.
struct StartResult {
  /// Rigid part, intra-operative → model: p_model ≈ transform · p_intra (a searched pose not
  /// accepted: the identity; a given pose: that pose).
  Eigen::Isometry3d transform = Eigen::Isometry3d::Identity();
  Vector3d bulk_shift = Vector3d::Zero();  ///< s (mm): the rest point is at transform·p − B s
  bool accepted = false;  ///< a searched pose beat the identity (false when the pose was given)
  /// The pose was given (IntraopData::pose: measured on another sweep, e.g. before the dura was
  /// opened), not searched on this sweep; a warm start keeps its first frame's.
  bool pose_given = false;
  /// The bulk shift was found: |s| ≥ bulk_min_mm after the pose search, or the bulk search's
  /// optimum beat s = 0 by its min_gain (else bulk_shift is zero).
  bool bulk_accepted = false;
  double score = 0.0;           ///< fine score at the result (kernel-weighted points)
  double score_identity = 0.0;  ///< fine score at the given or identity pose with s = 0
  /// The pose's distance from the identity in standard deviations of the navigation prior
  /// (√(|t|²/σ_t² + |w|²/σ_w²) per axis; 0 without a prior): above 3 the data moved the pose, and
  /// with it the fixed base, beyond what the navigation's stated accuracy allows.
  double prior_z = 0.0;
  double gain_z = 0.0;          ///< the blocks' mean gain over its standard error (see options)
  int gain_blocks = 0;          ///< blocks of significance_block_mm holding points
  double translation_mm = 0.0;  ///< motion of the centroid under transform (mm)
  double rotation_deg = 0.0;    ///< rotation angle of transform (degrees)
  int points = 0;               ///< points scored by the fine stage
  int candidates = 0;           ///< coarse local maxima rescored
  int refine_iterations = 0;    ///< ICP rounds of the winning refinement
  index_t pairs = 0;            ///< pairs of the last refinement round
  double rms_before_mm = 0.0;   ///< RMS distance of the pairs at the identity (pairs within τ_c)
  double rms_after_mm = 0.0;    ///< same at the result
  double seconds = 0.0;         ///< total, of which:
  double seconds_table = 0.0, seconds_coarse = 0.0, seconds_fine = 0.0, seconds_refine = 0.0;
  std::string message;  ///< the pose search's: what was found and why it was (not) kept
  /// The pose is in use: a searched pose that was accepted, a given or warm-started pose, or the
  /// identity asked for (report rigid.converged).
  bool converged = false;
  std::string stop_reason;   ///< how the pose was obtained, or why none was (rigid.stop_reason)
  std::string bulk_message;  ///< how the bulk shift was found, or why none was; empty: not searched
  /// The best searched pose distinct from the best one (GlobalStartOptions::ambiguity_*): its
  /// fine score over the best searched pose's (0 when every candidate is the same pose), and the
  /// RMS distance between where the two put the points (mm).
  double runner_up_ratio = 0.0;
  double runner_up_distance_mm = 0.0;
  /// The points' RMS spread about their centroid along their principal axes, largest first (mm).
  Vector3d spread_mm = Vector3d::Zero();
  bool ambiguous = false;  ///< an accepted pose that the data do not single out (see options)
  std::string ambiguity;   ///< why, when ambiguous
};

}  // namespace brainshift::constraints
