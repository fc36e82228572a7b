#pragma once
/// @file
/// @brief One stage of the registration schedule: Algorithm 1 of seed 002 (pair, filter, build
/// the rows, one constrained step, repeat) with this stage's pairing rule, vessel compliance,
/// trust region and stop test. register_model() (registration.hpp) runs the stages in order on
/// one LoopState. Positions in mm, model frame (the rigid start already applied to the data).

#include "constraints/registration/registration_types.hpp"

#include <array>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <vector>

namespace brainshift::constraints {

/// Everything a stage reads and no stage changes: the model, the data in the model frame, the
/// per-point and per-feature tables. Built once per registration.
struct LoopInputs {
  const RegistrationModel* model = nullptr;
  const RegistrationOptions* options = nullptr;
  bool vessels = false, footprint = false, landmarks = false, dura = false;
  /// IntraopData::pose is set (a pre-dura pose): the paired test's bar is then
  /// NoiseOptions::paired_test_z_with_pose.
  bool pose_given = false;
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
  /// response (RegistrationOptions::bulk_as_load); zero otherwise. Kept for a warm start.
  Vector3d bulk_gravity = Vector3d::Zero();
  /// That load's linear response as the elastic rest (core::RestShape, every step's
  /// StepOptions::rest): the load's equilibrium is the stress-free state, so the corotational
  /// iteration does not carry the load itself. Null without a bulk load.
  std::shared_ptr<const core::RestShape> bulk_rest;
  /// Where the HELD stage's first pairs are made (#N×3, model frame) when the iteration starts
  /// elsewhere (RegistrationOptions::start_at_load_rest: the rest nodes, the iterate at the load's
  /// rest); empty: at the iterate.
  MatrixX3d held_pairing_positions;
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
  /// End the stage STALLED when stage_stalled() says its clean steps cannot reach the tolerance
  /// within the cap, or when each of its last stall_window steps left elements inverted (the
  /// rows pulling elements through themselves, each step cut by the trust region: at 20.8k
  /// nodes a SMOOTH stage at a stiff chosen compliance held 1-6 inverted elements on each of
  /// its 40 steps to the cap; docs/BENCHMARKS.md): for a stage whose unsettled answer is
  /// discarded (SMOOTH), where running on to the cap would only cost time.
  bool stop_when_stalled = false;
};

/// Runs one stage from `state` (updated in place: positions, pairs, λ, history, times).
/// Never throws on non-convergence; a non-finite step leaves the positions at the last finite
/// iterate and returns DIVERGED.
StageRecord run_stage(const LoopInputs& in, const StageOptions& stage, LoopState& state);

/// Into `rec`: the node of the largest nodal increment of the step `dx` (#N×3, mm) that ended
/// at `x`, its position there, its share of ‖dx‖², and the largest increment of the nodes that
/// share no tetrahedron with it (0 when every node does). Node -1 for an empty or zero step.
void locate_increment(const core::TetMesh& mesh, const MatrixX3d& dx, const MatrixX3d& x,
                      IterationRecord& rec);

/// One clause for a stop reason: where the last step moved most and how much the mesh moved
/// beyond that node's elements ("" without a located step).
std::string describe_increment(const IterationRecord& last);

/// The data rows (vessels, footprint, landmarks; no dura) of a loop state at its final
/// positions: what predict_uncertainty() (uncertainty.hpp) conditions on, as
/// RegistrationResult::data_rows.
ConstraintRows data_rows_at(const LoopInputs& in, const LoopState& state);

/// A turn-back counts as a contracting oscillation when its step is at most this fraction of
/// the previous one (max nodal |Δx|, both made with the same pairs, this one not limited).
/// With the pairs fixed, near its fixed point the loop is x_{k+1} = G(x_k) with
/// Δx_{k+1} ≈ J Δx_k; a dominant eigenvalue λ < 0 of J turns every step back with
/// |Δx_{k+1}| / |Δx_k| → |λ|, and the iteration converges by itself iff |λ| < 1. So 1 is the
/// boundary and 0.9 leaves a margin for a one-step ratio's noise (the largest increment moves
/// between nodes; the element rotations change G a little from step to step): a
/// non-contracting oscillation has ratios of 1 or more on average, so a ratio that reads low
/// once costs one held radius, not a missed collapse. And 0.9 is about the slowest contraction that
/// can still settle in the loop's budget: from the 5 mm radius to the 0.01 mm tolerance at ratio
/// 0.9 takes ln 500 / ln(1/0.9) ≈ 59 steps of the 80 the HELD and FREE stages have together; a
/// slower one would not settle in time anyway, so shrinking it loses nothing that would have
/// converged.
inline constexpr double contraction_bound = 0.9;

/// DAMP: the share of each step taken (the damping α, 1 at a stage's start; the whole step is
/// scaled, like the trust region's limit but relative, so the loop's fixed points do not move)
/// is multiplied by this after a non-contracting reversal, and never goes below min_damping
/// (then such a turn-back shrinks the radius as any other). The damped loop moves a mode of
/// eigenvalue λ by 1 − α(1 − λ): a period-2 oscillation (λ ≈ −1.05, measured on the ICBM152
/// phantom with a pre-dura pose) becomes 1 − 0.6 · 2.05 ≈ −0.23 after one DAMP; three DAMPs
/// (0.6³ ≈ 0.22) reach any λ ≥ −8. Below 0.2 the steps are so short that a stop on their size
/// would not mean settled (the stop test asks max_increment < tolerance × α for that reason).
/// Damping only the elastic part (StepOptions::relaxation) was tried first: where compliant rows
/// hold a violation it moves the fixed point by (1 − α) C Hᵀ W⁻¹ δ.
inline constexpr double damp_factor = 0.6;
inline constexpr double min_damping = 0.2;
/// DAMP answers a reversal (cosine at most this), the signature of a period-2 oscillation
/// (measured −0.9 to −1.0); a weaker turn-back is a change of direction, which damping would
/// only slow (on the 20k-node model a turn-back at −0.12 was damped, and the loop then crept
/// at 0.9 a step), so it shrinks the radius as before.
inline constexpr double reversal_cosine = -0.5;
/// A reversal that contracts (same pairs and damping, not limited, cosine ≤ reversal_cosine)
/// with a length ratio r above this is damped as well, not held: its dominant mode is λ ≈ −r,
/// which left alone loses a decade only every ln 10 / ln(1/r) steps (6.5 at r = 0.7), and one
/// DAMP takes it to 1 − damp_factor (1 + r), within ±0.14 for r in (0.5, 0.9]. The price is that
/// a mode λ₊ > 0 slows to 1 − damp_factor (1 − λ₊) (0.5 → 0.7), which the tail jump takes at
/// once when it is the last one left. Below r = 0.5 the oscillation halves at each step by itself
/// and damping would only slow the rest. Measured: ICBM152 with a pre-dura pose, 3,982 nodes,
/// SMOOTH turning back at −0.57 to −0.77 and 0.69–0.83 a step: 38 → 33 iterations; 20.8k nodes
/// 70 → 63; the 13 cases × 3 seeds, every answer within 0.001 mm (docs/BENCHMARKS.md).
inline constexpr double slow_reversal_ratio = 0.5;

/// What the trust region reads of a step, against the step before it in the same stage.
struct SuccessiveSteps {
  /// Cosine between this increment and the previous one (all nodes, #N×3 flattened); nullopt for
  /// a stage's first step. Negative: the step turned back.
  std::optional<double> cosine;
  double length_ratio = 1.0;  ///< this step's max nodal |Δx| over the previous step's
  /// This step projected on the previous one, Δx_k·Δx_{k−1} / |Δx_{k−1}|² (all nodes): the
  /// factor of a map's iteration along the mode the two steps share (signed; 0 without one).
  double projected_ratio = 0.0;
  bool limited = false;  ///< this step was scaled down to the radius
  /// Both steps were made with the same pairs (HELD, FROZEN, or fresh pairs unchanged), so both
  /// iterate one map and their length ratio measures its contraction. Across a pairing change
  /// the steps answer different data and their ratio measures nothing of the kind.
  bool same_pairing = true;
  /// Both steps were made with the same damping. Right after a DAMP the previous step is an
  /// undamped one and the ratio compares two different maps: such a turn-back is held, so that
  /// one oscillation is damped once, not down to the floor in successive steps (on the 20k-node
  /// model that left a slow mode at 0.91 a step and the HELD stage at its cap).
  bool same_damping = true;
};

/// The trust region's rule, alone (radii in mm).
/// @param[in] steps this step against the previous one.
/// @param[in] max_radius the radius never grows beyond this.
/// @param[in,out] radius the radius the next step is limited to.
/// @return NONE without a previous step; GROW (× 1.5, up to `max_radius`) when the step did not
///   turn back (cosine ≥ 0); HOLD (unchanged)
///   when it turned back but contracted: same pairs, not limited and length_ratio ≤
///   contraction_bound (a converging oscillation, which halving would race to a NOT_SETTLING stop)
///   and DAMP below does not take it;
///   DAMP (damping × damp_factor, radius unchanged) when it reversed (cosine ≤ reversal_cosine)
///   without contracting, or contracting slowly (slow_reversal_ratio < length_ratio ≤
///   contraction_bound, same damping as the step before), same pairs, not limited, and the damping
///   is still above min_damping: the oscillation is the step's own overshoot, below the radius;
///   HOLD too for a turn-back right after a DAMP (same_damping false); SHRINK (× 0.5) otherwise: an
///   oscillation that damping did not end, or a turn-back across a pairing change, or a limited
///   step (whose length is the radius's and says nothing about contraction). Data the model cannot
///   meet keep turning back without contracting, and a radius below the increment tolerance ends
///   the stage NOT_SETTLING.
/// @param[in,out] damping the share of the next step taken, in [min_damping, 1].
TrustDecision trust_update(const SuccessiveSteps& steps, double max_radius, double& radius,
                           double& damping);

/// TAIL: a step made with the previous step's pairs and damping, neither cut to the radius,
/// along it or turned back (|cosine| ≥ tail_cosine) and contracting (|projected_ratio| ≤
/// contraction_bound), iterates one map near its fixed point along the modes the two steps
/// share: Δx_{k+1} ≈ ρ Δx_k with ρ = projected_ratio (signed). Returns ρ, or nullopt when the
/// step is not of that kind.
std::optional<double> tail_ratio(const SuccessiveSteps& steps);

/// Two successive steps' ratios (tail_ratio()) agree within this: the contraction is one mode's,
/// not a transient, and the rest of the geometric series can be taken at once.
inline constexpr double tail_ratio_agreement = 0.1;
/// |cosine| of a TAIL step: the increment keeps its direction (or reverses it) to within 45°.
/// Several modes contracting at nearly one rate turn the increment a little from step to step
/// (the tails of the 1.6k-node phantom: cosines 0.83-0.93 at ratios 0.62-0.66); the series'
/// sum is the same for all of them as long as the ratios agree, which the jump asks as well.
inline constexpr double tail_cosine = 0.7;

/// The factor f of the jump x ← x + f Δx that takes the rest of the geometric series
/// Σ_{j≥1} ρʲ Δx = ρ / (1 − ρ) Δx at once, when this step's ratio ρ and the previous step's agree
/// (both of the same sign, within tail_ratio_agreement); nullopt otherwise. With ρ exact (one
/// linear mode) the jump lands on the fixed point: Aitken's Δ² extrapolation, per mode. The
/// loop's fixed point does not move: the next step is taken from there with the same pairs, and
/// the stop test still asks that step to be below the tolerance.
std::optional<double> tail_jump_factor(std::optional<double> previous_ratio,
                                       std::optional<double> ratio);

/// Clean steps (the same pairs and damping as the step before, not cut to the radius, not turned
/// back from it (TrustDecision::GROW: an oscillation is the trust region's to damp or shrink), not
/// answering a tail jump) whose increments stage_stalled() reads: its window.
inline constexpr int stall_window = 6;

/// Whether a stage can still settle before its cap, from its last clean steps' increments a
/// (max nodal |Δx|, mm, oldest first, the latest last): with the pairs fixed, near its fixed point
/// the loop contracts geometrically, |Δx_{k+1}| ≈ ρ |Δx_k|, so ρ = (a_last / a_first)^(1/(w−1))
/// over the last w = stall_window of them, and the tolerance is reached after
/// log(tolerance / a_last) / log ρ more steps (never when ρ ≥ 1). True when that is more than
/// `remaining` (the iterations left before the cap), or when ρ ≥ 1 with a_last above the
/// tolerance; false with fewer than w clean steps. The fine meshes' SMOOTH stages creep at a
/// constant 0.025-0.03 mm per step for 30 steps, with 2-3 elements flipping, to the cap
/// (ICBM152 at 5,329 nodes; docs/BENCHMARKS.md).
bool stage_stalled(const std::vector<double>& clean_increments, double tolerance, int remaining);

}  // namespace brainshift::constraints
