#pragma once
/// @file
/// @brief One stage of the registration schedule: Algorithm 1 of seed 002 (pair, filter, build
/// the rows, one constrained step, repeat) with this stage's pairing rule, vessel compliance,
/// trust region and stop test. register_model() (registration.hpp) runs the stages in order on
/// one LoopState. Positions in mm, model frame (the rigid start already applied to the data).

#include "constraints/registration/registration.hpp"

#include <array>
#include <cstdint>
#include <map>
#include <set>
#include <vector>

namespace brainshift::constraints {

/// Everything a stage reads and no stage changes: the model, the data in the model frame, the
/// per-point and per-feature tables. Built once per registration.
struct LoopInputs {
  const RegistrationModel* model = nullptr;
  const RegistrationOptions* options = nullptr;
  bool vessels = false, footprint = false, landmarks = false, dura = false;
  MatrixX3d vessel_points;  ///< model frame
  MatrixX3d
      held_pair_points;  ///< where the HELD stage makes its pairs (the points less the bulk shift)
  MatrixX3d footprint_points, footprint_normals, landmark_targets;
  core::BarycentricMapping landmark_map;
  std::vector<Vector3d> directions;  ///< local direction of each vessel point
  std::vector<index_t> segment_tets, triangle_tets;
  std::vector<index_t>
      segment_blocks;  ///< cross-validation block of each skeleton segment (vessel_blocks.hpp)
  /// The start's rigid + bulk state (#N×3, model frame) when ε → ∞ stands for it
  /// (NoiseOptions::start_is_bulk_state); empty otherwise.
  MatrixX3d start_state;
  /// The body acceleration (mm/s², model frame) whose linear response is the start's bulk
  /// response (RegistrationOptions::bulk_as_load), added to every step's gravity; zero otherwise.
  Vector3d bulk_gravity = Vector3d::Zero();
};

using LambdaKey = std::array<std::int64_t, 3>;  ///< (set, feature, row within the group)

/// What carries from one iteration, and one stage, to the next.
struct LoopState {
  MatrixX3d positions;               ///< #N×3, model frame
  std::map<LambdaKey, double> warm;  ///< λ of the last step, by row key
  std::vector<Pair> vessel_pairs, footprint_pairs;
  std::vector<Pair> held_pairs;  ///< the HELD stage's final pairs (fallback of the stages after it)
  std::vector<IterationRecord> history;
  std::vector<StageRecord> stages;
  StageTimes seconds;
  std::array<index_t, num_constraint_sets> rows_by_set{};
  /// The last step's system (rows without compliance) for the noise model, and which rows are
  /// vessels.
  Eigen::MatrixXd last_delassus;
  Eigen::VectorXd last_delta_free;
  /// The last step's rows' gaps at LoopInputs::start_state, linearised: δ + H (x_start − x)
  /// (empty without a start state).
  Eigen::VectorXd last_delta_start;
  double last_scale = 0.0;
  std::vector<index_t> last_vessel_rows;
  std::vector<std::int64_t> last_vessel_features;  ///< the segment of each of last_vessel_rows
};

/// Settings of one stage.
struct StageOptions {
  StageKind kind = StageKind::FREE;
  int max_iterations = 80;
  double pair_distance_mm = 15.0;  ///< fresh pairs only within this (mm)
  bool keep_held_pairs = false;    ///< a point without a fresh pair keeps its HELD-stage feature
  double vessel_compliance_ratio = 0.2;
  bool keep_system = false;  ///< keep the last step's W and δ_free in the state (noise model)
};

/// Runs one stage from `state` (updated in place: positions, pairs, λ, history, times).
/// Never throws on non-convergence; a non-finite step leaves the positions at the last finite
/// iterate and returns DIVERGED.
StageRecord run_stage(const LoopInputs& in, const StageOptions& stage, LoopState& state);

/// The trust region's rule, alone: given the cosine between this increment and the previous
/// one (nullopt for a stage's first step), the new radius and the decision. Halves on a negative
/// cosine (the step turned back: oscillation), grows by 1.5× up to `max_radius` otherwise.
TrustDecision trust_update(std::optional<double> cosine, double max_radius, double& radius);

}  // namespace brainshift::constraints
