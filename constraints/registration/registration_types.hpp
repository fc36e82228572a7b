#pragma once
/// @file
/// @brief The registration's types, at the bottom of the registration: the intra-operative data
/// (IntraopData), the options (RegistrationOptions, whose scene keys visit_fields names), the
/// result with its per-iteration and per-stage history (RegistrationResult) and the statuses. The
/// start, the stage loop, the noise model and the predicted error include this, never
/// registration.hpp (the entry points, above them). Positions in mm, world (RAS) frame of the
/// pre-operative model; intra-operative points in their tracked frame (IntraopData).

#include "constraints/registration/noise/noise_model.hpp"
#include "constraints/registration/pairing/filtering.hpp"
#include "constraints/registration/registration_model.hpp"
#include "constraints/registration/rows/constraint_builders.hpp"
#include "constraints/registration/start/global_start.hpp"
#include "constraints/registration/uncertainty/uncertainty_options.hpp"
#include "constraints/solver/constrained_step.hpp"
#include "core/geometry/skeleton.hpp"
#include "core/mapping/barycentric_mapping.hpp"
#include "core/mesh/tet_mesh.hpp"

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace brainshift::constraints {

/// Intra-operative data, in the tracked intra-operative frame (mm; RAS world when tracking is
/// registered to the pre-operative images).
struct IntraopData {
  MatrixX3d vessel_points;     ///< from power Doppler, #V×3
  MatrixX3d footprint_points;  ///< probe footprint from B-mode, #P×3
  MatrixX3d
      footprint_normals;  ///< #P×3 unit normals pointing into the tissue (empty: from the surface)
  /// Optional landmarks: pre-operative model points (#L×3, rest frame) and where they are now
  /// (#L×3, intra-operative frame), e.g. a tracked pointer on a vessel bifurcation.
  MatrixX3d landmark_model_points;
  MatrixX3d landmark_targets;
  /// Optional: the navigation offset measured before the dura was opened (model ← tracked frame,
  /// p_model = pose · p_intra; e.g. the rigid start of a pre-dura sweep, pre_dura_pose()). Given,
  /// it replaces the pose search of the start: a sweep made after the dura is opened cannot tell
  /// a pose from the sag it sees as a near-uniform shift, and a pose that absorbs the sag moves
  /// the whole model, fixed base included (docs/history/BENCHMARKS_NOTEBOOK.md, "The bulk shift as
  /// a load, and the pose from a pre-dura sweep"). The bulk shift is then searched in that frame
  /// (start_at_pose(), bulk_search.hpp).
  std::optional<Eigen::Isometry3d> pose;
};

/// How the loop starts: IDENTITY (the tracked frame is the model frame; only the bulk shift is
/// searched, by the bulk search) or RIGID (the global start: rigid pose plus bulk response).
enum class RigidStart { IDENTITY, RIGID };
/// Names of RigidStart in the scene (`start`), reports and the command line (`--init`).
constexpr std::array<core::EnumName<RigidStart>, 2> enum_names(RigidStart /*tag*/) {
  return {{{RigidStart::IDENTITY, "identity"}, {RigidStart::RIGID, "rigid"}}};
}

/// RegistrationOptions::bulk_as_load.
enum class BulkLoad : std::uint8_t { AUTO, ON, OFF };
constexpr std::array<core::EnumName<BulkLoad>, 3> enum_names(BulkLoad /*tag*/) {
  return {{{BulkLoad::AUTO, "auto"}, {BulkLoad::ON, "on"}, {BulkLoad::OFF, "off"}}};
}

/// The registration's options. The scene keys (visit_fields below; `brainshift options` lists
/// them with their defaults, docs/OPTIONS.md) are the product's settings; the members that are not
/// scene keys are constants of the method (search grids, kernel widths, solver safeguards) and the
/// alternatives `brainshift bench` compares against the default (its ablation variants). The
/// defaults here are the product's: a library caller and the command line run the same algorithm.
struct RegistrationOptions {
  /// RIGID: the global start (rigid pose plus the model's bulk response, global_start.hpp).
  /// IDENTITY: the tracked frame taken as the model frame; only the bulk shift is searched.
  RigidStart start = RigidStart::RIGID;
  /// The start's options, one set (global_start.hpp): with start = RIGID the search of the pose
  /// and the bulk shift, kept only when it matches the vessels better than the identity; with the
  /// pose known (a pre-dura pose, or start = IDENTITY) the bulk search alone
  /// (GlobalStartOptions::bulk_search, scene keys shift_search.*). The bulk shift (the model's
  /// bounded load response, default_global_start()) seeds the first stage's pairs.
  GlobalStartOptions global_start = default_global_start();
  /// When the start's bulk shift is accepted, the first pairs are made at the shifted points
  /// (pᵢ − shift) and held (each point keeps its feature) until the model has settled on them, at
  /// most `shift_stage_iterations` iterations; free nearest-feature pairing takes over from there.
  /// Nearest-feature pairing from the rest shape picks the neighbouring vessel once the shift
  /// exceeds the vessel spacing; pairs made after the bulk shift is taken out do not.
  int shift_stage_iterations = 40;
  /// Shape of the searched shift: the model's own response to a uniform load (one per axis,
  /// normalised to the identity on average over the points) instead of a translation. The
  /// response follows the boundary conditions (nodes near the fixed base move less than the
  /// cortex under the probe), which a translation of a 6 cm deep field of view cannot; the
  /// direction and size of the shift are still searched, not assumed.
  bool shift_load_basis = true;
  /// Whether the start's bulk shift, when accepted, stays in the model as the load it is the
  /// response to (a body acceleration, like the gravity that makes the sag): the elastic model's
  /// rest, which compliant rows are pulled back towards, is then the bulk-shifted state instead
  /// of the pre-operative shape. A compliant row balances the elastic force of the displacement
  /// it holds, so from the rest shape it lags the data by a share of it; with the load only the
  /// part the load does not explain lags. The price is a prior of the load response's shape over
  /// the whole brain. Measured (docs/history/BENCHMARKS_NOTEBOOK.md, "The bulk shift as a load, and
  /// the pose from a pre-dura sweep"): after the pose-searching start (whose pose has absorbed most
  /// of the sag) mean landmark TRE 1.26 → 1.17 mm over the twelve phantom cases, but worse on the
  /// unit tests' analytic sag (not a load response), on 9 vessel points (a load from nine points
  /// moves the whole brain) and across a warm start whose shift changed; with the pose given
  /// (a pre-dura sweep) the bulk shift is the sag itself and the load takes standard from 1.52
  /// to 1.35 mm. AUTO: on when the pose is given (IntraopData::pose), else off. Needs
  /// shift_load_basis. A warm start keeps the previous frame's load.
  /// The load is carried as a pre-strained elastic rest (core::RestShape: the rest nodes plus
  /// its linear response), not as a body force: the same load in the linear model, but the
  /// corotational iteration then starts from a stress-free state instead of carrying a 20 mm
  /// load, under which it did not settle (large_shift with a pre-dura pose: 28 elements inverted,
  /// iteration cap, 3.9 mm; as the rest: converged, 0.95 mm; docs/history/BENCHMARKS_NOTEBOOK.md).
  BulkLoad bulk_as_load = BulkLoad::AUTO;
  /// With a bulk load (bulk_as_load) and no warm start, the iteration starts at the load's rest
  /// (the rest nodes plus its linear response, where the elastic force is zero) instead of at the
  /// rest nodes; the HELD stage's first pairs are still made at the rest nodes, so the pairs, the
  /// equilibrium and the stop test are the same and only the path to them is shorter: from the
  /// rest nodes the first steps are the model falling into the load's rest, cut to the trust
  /// radius (a 15 mm sag: four 5 mm steps). Not where the load's response flattens or inverts
  /// an element (core::RestShape::degenerate > 0). Off: the former start (bench variant
  /// `pre_dura_from_rest`; on the 13 cases the same errors, iterations 0-25 fewer).
  bool start_at_load_rest = true;
  /// A stage's tail, contracting along one mode with the same pairs (two successive steps'
  /// ratios agree: tail_jump_factor(), registration_stage.hpp), takes the rest of its geometric
  /// series at once instead of step by step. The fixed point and the stop test are unchanged (the
  /// step after the jump must still be below the tolerance). Off: every step taken (bench variant
  /// `pre_dura_no_tail`).
  bool extrapolate_tails = true;
  /// The SMOOTH stage, whose answer is discarded unless it settles, ends STALLED as soon as its
  /// clean steps' contraction cannot reach the tolerance before its cap (stage_stalled(),
  /// registration_stage.hpp): the same answer (the FREE stage's) without the steps to the cap.
  bool stop_stalled_smoothing = true;
  /// After the bulk-shift stage, fresh pairs only within this distance (mm): the shift is taken
  /// out, so a feature farther away is another vessel. A point with none keeps its stage-1 feature.
  double refine_pair_distance_mm = 2.0;
  bool use_vessels = true;
  bool use_footprint = true;
  bool use_landmarks = true;
  DuraOptions dura;                    ///< contact with the dura outside the craniotomy
  double pair_max_distance_mm = 15.0;  ///< no pair beyond this
  FilterOptions vessel_filter = default_vessel_filter();
  FilterOptions footprint_filter;
  double direction_radius_mm = 5.0;  ///< neighbourhood for the local direction of vessel points
  StepOptions step = default_step();
  int max_iterations = 80;  ///< HELD + FREE stages together (SMOOTH: noise.max_iterations)
  double increment_tolerance_mm = 0.01;  ///< stop when max nodal |Δx| is below this and the
                                         ///< pairing set is stable (unchanged or frozen)
  NoiseOptions noise;  ///< the vessel rows' compliance from the data (SMOOTH stage)
  /// A registration on vessels alone is not trusted (stop INSUFFICIENT_DATA, exit 2) with fewer
  /// paired vessel points than this at the end, or with a scatter (noise model) above
  /// max_scatter_mm: the answer is written but says why it should not be relied on.
  index_t min_vessel_pairs = 20;
  double max_scatter_mm = 3.0;
  /// A warm-started registration (replay) that does not converge is run again from the rest
  /// shape with the full start; the cold answer is kept when it converges.
  bool cold_retry = true;
  /// A cold registration that carried the bulk shift as a load (bulk_as_load) and ended
  /// NOT_SETTLING or at the iteration cap is run again with the bulk shift as the start's
  /// positions only (BulkLoad::OFF); that answer is kept when it converges (load_retry in the
  /// result). Where the load's pre-strained rest and the held pairs pull elements of a fine mesh
  /// through themselves (ICBM152 at 5,894 nodes: 13-17 inverted, exit 2), the load-free path
  /// settles (99 iterations, TRE 0.98 mm); elsewhere the load is the better path (ICBM152 at
  /// 3,982 nodes: 0.68 against 1.02 mm), so it stays first.
  bool load_retry = true;
  /// The predicted error of the answer (uncertainty.hpp: predict_uncertainty()); not used by
  /// the loop itself.
  UncertaintyOptions uncertainty;
  /// Fault injection for tests: called with every step's result as it will be taken (after a
  /// DAMP's scaling), before the loop looks at it.
  std::function<void(StepResult&)> inspect_step;
  /// Empty when valid, else what is wrong.
  [[nodiscard]] std::string validate() const;
  /// Vessel filter defaults: at most 2 rows per tetrahedron (soft rows tolerate more than one;
  /// 1 discards half the data on a 7 mm mesh).
  static FilterOptions default_vessel_filter();
  /// The step settings the loop is tuned for: vessel rows compliant with ratio 0.2 (see
  /// StepOptions::compliance_ratio; Doppler points are noisy), footprint, dura and landmark rows
  /// hard (the probe is rigid, few points), a 5 mm trust region, PGS to 1e-4 or 500 sweeps (each
  /// iteration re-solves from a warm start; a tighter solve per iteration buys nothing).
  static StepOptions default_step();
  /// The global start's defaults with bulk_response off (see global_start).
  static GlobalStartOptions default_global_start();
};

/// The scene keys' names, ranges and documentation (core/option_fields.hpp): `start` and the
/// groups global_start, shift_search, constraints, craniotomy, pairing, filter, solver, noise,
/// acceptance and uncertainty. Members not named here are not scene keys (see the struct's doc).
template <class V>
void visit_fields(RegistrationOptions& o, V&& v) {
  v("start", o.start,
    "rigid: the global search of the pose and the bulk shift; identity: the tracked frame is "
    "taken as right, only the bulk shift is searched");
  v.nest("global_start.", o.global_start);
  v.nest("shift_search.", o.global_start.bulk_search);
  v("constraints.vessels", o.use_vessels, "register on the vessel points");
  v("constraints.footprint", o.use_footprint, "register on the probe footprint");
  v("constraints.landmarks", o.use_landmarks, "register on landmarks");
  v.nest("", o.dura);
  v("pairing.max_distance_mm", o.pair_max_distance_mm, core::Range{1e-6, 1000},
    "no pair beyond this (mm)");
  v("pairing.direction_radius_mm", o.direction_radius_mm, core::Range{1e-6, 1000},
    "neighbourhood of the local direction of the vessel points (mm)");
  v("pairing.refine_distance_mm", o.refine_pair_distance_mm, core::Range{1e-6, 1000},
    "after the bulk-shift stage, fresh pairs only within this (mm)");
  v.nest("filter.vessels.", o.vessel_filter);
  v.nest("filter.footprint.", o.footprint_filter);
  v.nest("solver.", o.step);
  v("solver.max_iterations", o.max_iterations, core::Range{1, 100000},
    "iterations of the HELD and FREE stages together");
  v("solver.increment_tolerance_mm", o.increment_tolerance_mm, core::Range{1e-9, 100},
    "settled when the largest nodal increment is below this (mm)");
  v("solver.cold_retry", o.cold_retry, "a warm start that does not converge is rerun cold");
  v.nest("noise.", o.noise);
  v("acceptance.min_vessel_pairs", o.min_vessel_pairs, core::Range{0, 1e9},
    "fewer paired vessel points at the end: INSUFFICIENT_DATA");
  v("acceptance.max_scatter_mm", o.max_scatter_mm, core::Range{1e-6, 1000},
    "a larger scatter of the vessel points: INSUFFICIENT_DATA (mm)");
  v.nest("uncertainty.", o.uncertainty);
}

/// Seconds per stage, summed over iterations.
struct StageTimes {
  double rigid = 0.0;    ///< the start (global start, or the bulk-shift search from the identity)
  double pairing = 0.0;  ///< pairing, filtering, building the rows
  double free_motion = 0.0;  ///< element rotations, forces, one solve
  double delassus = 0.0;     ///< W = H C Hᵀ
  double pgs = 0.0;
  double correction = 0.0;
  double noise = 0.0;  ///< the noise model (one eigendecomposition of the vessel rows' W)
  double total = 0.0;
};

/// Stages of the schedule (see the file comment).
enum class StageKind : std::uint8_t { HELD, FREE, SMOOTH };
std::string to_string(StageKind kind);

/// How an iteration made its vessel pairs.
enum class PairingMode : std::uint8_t {
  FRESH,   ///< nearest feature, filtered
  HELD,    ///< HELD stage: the features chosen at its first iteration (made at the points less the
           ///< bulk shift)
  FROZEN,  ///< the pairing cycled: each point keeps its feature, the closest point is recomputed
};
std::string to_string(PairingMode mode);

/// What the trust region did after an iteration's step.
enum class TrustDecision : std::uint8_t {
  NONE,    ///< first step of a stage, or the stage ended
  GROW,    ///< the step continued the previous one: radius × 1.5 (up to the maximum)
  HOLD,    ///< the step turned back but contracted (same pairs as the previous step, not
           ///< limited, max_increment_mm at most 0.9× the previous step's): a converging
           ///< oscillation, radius unchanged
  SHRINK,  ///< the step turned back otherwise (no clear contraction of one map's iteration: an
           ///< oscillation that may not settle by itself): radius × 0.5
  DAMP,    ///< the step turned back without contracting, with the same pairs and below the
           ///< radius (a period-2 oscillation of the mechanics' quasi-Newton iteration, which a
           ///< radius does not reach until it binds): the elastic part of the following steps is
           ///< damped (the share of each step taken × damp_factor, down to min_damping), radius
           ///< unchanged
};
std::string to_string(TrustDecision d);

/// One iteration of the loop.
struct IterationRecord {
  StageKind stage = StageKind::FREE;
  PairingMode pairing = PairingMode::FRESH;
  index_t vessel_pairs = 0;  ///< kept after filtering
  index_t footprint_pairs = 0;
  index_t dura_rows = 0;
  index_t landmark_rows = 0;
  index_t rows = 0;
  double max_increment_mm = 0.0;
  /// Where that largest nodal increment was (locate_increment(), registration_stage.hpp): the
  /// node (-1: no step), its position after the step (mm, model frame), its share of the step's
  /// squared length, and the largest increment of the nodes that share no element with it (mm).
  /// A failure to settle that is one node's (an element pulled through itself) reads as a share
  /// near 1 and a remainder below the tolerance.
  index_t max_increment_node = -1;
  Vector3d max_increment_at = Vector3d::Zero();
  double max_increment_share = 0.0;
  double increment_beyond_mm = 0.0;
  int pgs_iterations = 0;
  double pgs_residual = 0.0;
  PgsStop pgs_stop = PgsStop::NO_ROWS;
  bool pairing_changed = true;
  bool pairing_frozen = false;
  bool finite = true;  ///< the step's increment was finite (else the loop stopped DIVERGED)
  double seconds = 0.0;
  double trust_radius_mm = 0.0;  ///< the trust region this iteration's step was limited to
  bool limited = false;          ///< the step was scaled down to the trust region
  TrustDecision trust = TrustDecision::NONE;
  double damping = 1.0;  ///< the share of this iteration's step taken (DAMP lowers it)
  double vessel_compliance_ratio = 0.0;  ///< of this iteration's vessel rows
  FilterReport vessel_filter;
  FilterReport footprint_filter;
  std::string diagnosis;          ///< the step's diagnosis, if any
  index_t inverted_elements = 0;  ///< elements inverted at the start of this iteration's step
  /// Max nodal length of the TAIL jump taken after this iteration's step (0: none), mm.
  double extrapolated_mm = 0.0;
};

enum class RegistrationStop {
  CONVERGED,          ///< increment below tolerance with a stable (or frozen) pairing set
  MAX_ITERATIONS,     ///< iteration cap
  NO_DATA,            ///< nothing to register; the model was not moved
  NOT_SETTLING,       ///< the trust region shrank below the increment tolerance: the model cannot
                      ///< meet the constraints (inconsistent data, or beyond the corotational
                      ///< iteration's reach); positions are the last finite iterate
  DIVERGED,           ///< a step's increment was not finite; positions are the start's state
  INSUFFICIENT_DATA,  ///< settled, but on too few or too scattered vessel points to be trusted;
                      ///< positions are the model at rest in the rigid-only pose (cold; the
                      ///< given pose plus the bulk response with a pre-dura sweep) or the warm
                      ///< start's (RegistrationResult::start_returned)
  AMBIGUOUS_POSE,     ///< settled, but the global start's pose is not singled out by the data
                      ///< (StartResult::ambiguous: another distinct pose scores nearly as
                      ///< well, or the points cannot pin a rotation); the positions are the
                      ///< loop's, not to be relied on
};
std::string to_string(RegistrationStop stop);

/// How a stage ended.
enum class StageStop : std::uint8_t {
  SETTLED,        ///< increment below tolerance (and, except HELD, a stable or frozen pairing set)
  ITERATION_CAP,  ///< its iteration cap
  NOT_SETTLING,   ///< its trust region shrank below the increment tolerance
  DIVERGED,       ///< a non-finite step
  /// Its clean steps (same pairs and damping, none cut) stopped contracting: at their measured
  /// rate the increment tolerance would not be reached within the cap (stage_stalled()); only
  /// in a stage whose unsettled answer is discarded (StageOptions::stop_when_stalled).
  STALLED,
};
std::string to_string(StageStop stop);

/// One stage of the schedule, as run.
struct StageRecord {
  StageKind kind = StageKind::FREE;
  StageStop stop = StageStop::ITERATION_CAP;
  int first_iteration = 0;  ///< 1-based, in RegistrationResult::history
  int iterations = 0;
  double vessel_compliance_ratio = 0.0;
};

struct RegistrationResult {
  MatrixX3d positions;     ///< final nodal positions #N×3, model frame, mm
  MatrixX3d displacement;  ///< positions − rest, mm
  /// The start (start/start_result.hpp): the pose (p_model ≈ start.transform · p_intra; the
  /// identity when start is IDENTITY or the searched pose was not accepted; a given or warm
  /// start's own) and the first stage's bulk shift (start.bulk_accepted false when none or
  /// warm-started), with the evidence for both.
  StartResult start;
  int iterations = 0;
  bool converged = false;
  RegistrationStop stop = RegistrationStop::NO_DATA;
  std::string stop_reason;
  std::vector<IterationRecord> history;
  std::vector<StageRecord> stages;  ///< in the order run
  NoiseEstimate noise;              ///< the noise model's estimate (valid = false when not run)
  bool cold_retry = false;          ///< a warm start did not converge and this is the cold answer
  /// The bulk load's path did not converge and this is the answer without it
  /// (RegistrationOptions::load_retry).
  bool load_retry = false;
  /// The loop stopped DIVERGED or INSUFFICIENT_DATA, so its deformed state is not returned:
  /// positions are the start's state instead — the model at rest plus the global start's bulk
  /// response (DIVERGED, and INSUFFICIENT_DATA with a given pose), the model at rest in the
  /// rigid-only pose (INSUFFICIENT_DATA), the rigid transform in `rigid`; or a warm start's
  /// positions — and `lambda` is empty. The stop and its reason are kept (exit 2); `history`
  /// still records what was tried.
  bool start_returned = false;
  std::array<index_t, num_constraint_sets> rows_by_set{};  ///< of the last iteration
  StageTimes seconds;
  /// The data rows (vessels, footprint, landmarks; no dura) of the last pairs, rebuilt at the
  /// final positions: what the predicted error (uncertainty.hpp) conditions on. Empty with NO_DATA.
  ConstraintRows data_rows;
  /// The vessel rows' compliance ratio of the answer kept (the FREE stage's, or SMOOTH's when it
  /// settled).
  double vessel_compliance_ratio = 0.0;
  /// The body acceleration (mm/s², model frame) that carried the bulk shift in every step
  /// (RegistrationOptions::bulk_as_load; zero when none); a warm start reuses it.
  Vector3d bulk_gravity = Vector3d::Zero();
  /// Warm-start state: λ per (set, feature, row) of the last iteration, for the next frame.
  std::vector<std::pair<std::array<std::int64_t, 3>, double>> lambda;
};

}  // namespace brainshift::constraints
