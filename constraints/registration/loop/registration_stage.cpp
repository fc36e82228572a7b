#include "constraints/registration/loop/registration_stage.hpp"

#include "constraints/registration/pairing/pairing.hpp"
#include "core/error.hpp"
#include "core/logger.hpp"
#include "core/timing.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>

namespace brainshift::constraints {
namespace {

using core::Clock;
using core::seconds_since;

using PairKey = std::array<std::int64_t, 3>;  // (set, point, feature)

/// Warm-start key of every row: (set, feature, position of the row within its group).
std::vector<LambdaKey> lambda_keys(const ConstraintRows& rows) {
  std::vector<LambdaKey> keys;
  keys.reserve(static_cast<std::size_t>(rows.size()));
  for (index_t i = 0, k = 0; i < rows.size(); ++i) {
    k = (i > 0 && rows[i].group == rows[i - 1].group) ? k + 1 : 0;
    keys.push_back({static_cast<std::int64_t>(rows[i].set), rows[i].feature, k});
  }
  return keys;
}

/// Each held pair re-closed on its own feature at the current positions.
std::vector<Pair> reclose(const FeatureIndex& index, ConstRef<MatrixX3d> points,
                          const std::vector<Pair>& held) {
  std::vector<Pair> pairs;
  pairs.reserve(held.size());
  for (const Pair& f : held) {
    Pair p = index.closest_on(f.feature, points.row(f.point).transpose());
    p.point = f.point;
    pairs.push_back(p);
  }
  return pairs;
}

/// Nearest-feature pairs within max_distance, filtered.
std::vector<Pair> fresh_pairs(const FeatureIndex& index, ConstRef<MatrixX3d> points,
                              const std::vector<Vector3d>& directions,
                              const std::vector<index_t>& tet_of_feature, double max_distance,
                              const FilterOptions& filter, FilterReport* report) {
  std::vector<Pair> pairs = index.pair(points, max_distance);
  std::vector<index_t> tets;
  tets.reserve(pairs.size());
  for (const Pair& p : pairs) tets.push_back(tet_of_feature[static_cast<std::size_t>(p.feature)]);
  return filter_pairs(std::move(pairs), directions, tets, filter, report);
}

/// After the bulk shift: a point that found no feature within the refinement distance keeps the
/// feature it was given in the HELD stage (unless another point took that feature). Without it,
/// points drop out one after the other — the model relaxes towards the rest shape where it loses
/// rows, which moves more points out of reach — until nothing holds the shift.
void keep_held_pairs(std::vector<Pair>& pairs, const std::vector<Pair>& held,
                     const FeatureIndex& index, ConstRef<MatrixX3d> points) {
  std::set<index_t> paired, taken;
  for (const Pair& p : pairs) {
    paired.insert(p.point);
    taken.insert(p.feature);
  }
  for (const Pair& h : held)
    if (!paired.count(h.point) && !taken.count(h.feature)) {
      Pair p = index.closest_on(h.feature, points.row(h.point).transpose());
      p.point = h.point;
      pairs.push_back(p);
    }
  std::sort(pairs.begin(), pairs.end(),
            [](const Pair& a, const Pair& b) { return a.point < b.point; });
}

}  // namespace

TrustDecision trust_update(const SuccessiveSteps& steps, double max_radius, double& radius,
                           double& damping) {
  if (!steps.cosine) return TrustDecision::NONE;
  if (*steps.cosine >= 0.0) {
    radius = std::min(max_radius, 1.5 * radius);
    return TrustDecision::GROW;
  }
  // A turn-back. A reversal (one map's iteration: the same pairs and damping, not limited) that
  // does not contract, or contracts only slowly, is the step's own overshoot: damped. Any other
  // turn-back of one map that contracts, or that follows a DAMP, is a converging oscillation,
  // which halving would only race: held. A limited step's length is the radius's and says nothing
  // about contraction.
  const bool one_map = steps.same_pairing && !steps.limited;
  if (one_map && steps.same_damping && *steps.cosine <= reversal_cosine &&
      steps.length_ratio > slow_reversal_ratio && damping * damp_factor >= min_damping) {
    damping *= damp_factor;
    return TrustDecision::DAMP;
  }
  if (one_map && (steps.length_ratio <= contraction_bound || !steps.same_damping))
    return TrustDecision::HOLD;
  radius *= 0.5;
  return TrustDecision::SHRINK;
}

std::optional<double> tail_ratio(const SuccessiveSteps& steps) {
  if (!steps.cosine || !steps.same_pairing || !steps.same_damping || steps.limited)
    return std::nullopt;
  if (std::abs(*steps.cosine) < tail_cosine) return std::nullopt;
  if (!(std::abs(steps.projected_ratio) <= contraction_bound && steps.projected_ratio != 0.0))
    return std::nullopt;
  return steps.projected_ratio;
}

std::optional<double> tail_jump_factor(std::optional<double> previous_ratio,
                                       std::optional<double> ratio) {
  if (!previous_ratio || !ratio || (*previous_ratio > 0.0) != (*ratio > 0.0) ||
      std::abs(*ratio - *previous_ratio) > tail_ratio_agreement)
    return std::nullopt;
  return *ratio / (1.0 - *ratio);
}

namespace {

/// What one stage carries from an iteration to the next: the trust region, the damping, the
/// last increment (for the oscillation test) and the pairing sets seen (for the cycle test).
struct StageLoop {
  double max_radius = std::numeric_limits<double>::infinity();
  double radius = std::numeric_limits<double>::infinity();
  double damping = 1.0;                      // the share of each step taken; DAMP lowers it
  double previous_damping = 1.0;             // the previous step's
  MatrixX3d previous_dx;                     // the last step's increment, for the oscillation test
  double previous_increment = 0.0;           // its max nodal |Δx| (mm)
  std::vector<std::set<PairKey>> pair_sets;  // per iteration of this stage
  bool frozen = false;
  std::optional<double> previous_tail_ratio;  // the last step's tail_ratio()
  std::vector<double> clean_increments;       // the current run of clean steps (stage_stalled())
};

/// Algorithm 1, steps 1-2: the vessel and footprint pairs of iteration `it`, by the stage's rule
/// (held, frozen or fresh), filtered; into `state`, what was done into `rec`.
void pair_and_filter(const LoopInputs& in, const StageOptions& stage, int it, bool frozen,
                     LoopState& state, IterationRecord& rec) {
  const RegistrationModel& model = *in.model;
  const RegistrationOptions& options = *in.options;
  if (in.vessels) {
    const FeatureIndex index = FeatureIndex::segments(
        model.skeleton_mapping().apply(state.positions), model.skeleton().segments);
    if (stage.kind == StageKind::HELD) {
      rec.pairing = PairingMode::HELD;
      if (it == 1) {
        const bool elsewhere = in.held_pairing_positions.rows() > 0;
        std::optional<FeatureIndex> at_rest;
        if (elsewhere)
          at_rest = FeatureIndex::segments(
              model.skeleton_mapping().apply(in.held_pairing_positions), model.skeleton().segments);
        const std::vector<Pair> pairs = fresh_pairs(
            elsewhere ? *at_rest : index, in.held_pair_points, in.directions, in.segment_tets,
            options.pair_max_distance_mm, options.vessel_filter, &rec.vessel_filter);
        // Pairs made elsewhere are closed at the iterate (their features' nearest points there).
        state.vessel_pairs = elsewhere ? reclose(index, in.vessel_points, pairs) : pairs;
      } else {
        state.vessel_pairs = reclose(index, in.vessel_points, state.vessel_pairs);
      }
    } else if (frozen) {
      rec.pairing = PairingMode::FROZEN;
      state.vessel_pairs = reclose(index, in.vessel_points, state.vessel_pairs);
    } else {
      rec.pairing = PairingMode::FRESH;
      state.vessel_pairs =
          fresh_pairs(index, in.vessel_points, in.directions, in.segment_tets,
                      stage.pair_distance_mm, options.vessel_filter, &rec.vessel_filter);
      if (stage.keep_held_pairs)
        keep_held_pairs(state.vessel_pairs, state.held_pairs, index, in.vessel_points);
    }
    rec.vessel_pairs = static_cast<index_t>(state.vessel_pairs.size());
  }
  if (in.footprint) {
    const FeatureIndex index = FeatureIndex::triangles(
        model.surface_mapping().apply(state.positions), model.surface().triangles);
    state.footprint_pairs = frozen ? reclose(index, in.footprint_points, state.footprint_pairs)
                                   : fresh_pairs(index, in.footprint_points, {}, in.triangle_tets,
                                                 options.pair_max_distance_mm,
                                                 options.footprint_filter, &rec.footprint_filter);
    rec.footprint_pairs = static_cast<index_t>(state.footprint_pairs.size());
  }
}

/// Algorithm 1, step 3: the rows of the pairs (vessels, then the footprint), the dura's and the
/// landmarks'; returns the pairing's keys.
std::set<PairKey> build_rows(const LoopInputs& in, const LoopState& state, IterationRecord& rec,
                             ConstraintRows& rows) {
  const RegistrationModel& model = *in.model;
  const core::TetMesh& mesh = model.mesh();
  std::set<PairKey> keys;
  if (in.vessels) {
    const MappedVertices skel{&mesh, &model.skeleton_mapping()};
    add_vessel_rows(rows, state.vessel_pairs, model.skeleton(), skel, state.positions,
                    in.vessel_points);
    for (const Pair& p : state.vessel_pairs) keys.insert({0, p.point, p.feature});
  }
  const MappedVertices surf{&mesh, &model.surface_mapping()};
  std::vector<bool> touched;
  if (in.footprint) {
    add_footprint_rows(rows, state.footprint_pairs, model.surface(), surf, state.positions,
                       in.footprint_points, in.footprint_normals);
    touched.assign(static_cast<std::size_t>(model.surface().vertices.rows()), false);
    const auto& tris = model.surface().triangles;
    for (const Pair& p : state.footprint_pairs) {
      keys.insert({1, p.point, p.feature});
      for (int k = 0; k < 3; ++k) touched[static_cast<std::size_t>(tris(p.feature, k))] = true;
    }
  }
  if (in.dura)
    rec.dura_rows =
        add_dura_rows(rows, in.options->dura, model.surface(), *model.rest_surface_index(),
                      model.rest_surface_normals(), surf, state.positions, touched);
  if (in.landmarks) {
    const MappedVertices lmk{&mesh, &in.landmark_map};
    add_landmark_rows(rows, lmk, state.positions, in.landmark_targets);
    rec.landmark_rows = 3 * static_cast<index_t>(in.landmark_targets.rows());
  }
  rec.rows = rows.size();
  return keys;
}

/// Algorithm 1, step 4: one constrained step from the state's positions, λ warm-started by row
/// key, within the trust radius and scaled by the damping; what it did into `rec` and the
/// state's times.
StepResult take_step(const LoopInputs& in, const ConstraintRows& rows,
                     const std::vector<LambdaKey>& keys_of_rows, const StageLoop& loop,
                     StepOptions& step_options, LoopState& state, IterationRecord& rec) {
  Eigen::VectorXd lambda0 = Eigen::VectorXd::Zero(rows.size());
  for (index_t i = 0; i < rows.size(); ++i)
    if (auto f = state.warm.find(keys_of_rows[static_cast<std::size_t>(i)]); f != state.warm.end())
      lambda0[i] = f->second;
  step_options.max_increment = std::isfinite(loop.radius) ? loop.radius : 0.0;
  rec.damping = loop.damping;
  StepResult step = in.model->mechanics().step(state.positions, rows, step_options, lambda0);
  if (loop.damping < 1.0) {
    // DAMP: the whole step scaled, so that the fixed points stay the loop's own (damping the
    // elastic part alone, StepOptions::relaxation, moves them where compliant rows hold a
    // violation).
    step.x = state.positions + loop.damping * (step.x - state.positions);
    step.max_increment *= loop.damping;
  }
  if (in.options->inspect_step) in.options->inspect_step(step);
  rec.trust_radius_mm = step_options.max_increment;
  rec.limited = step.limited;
  rec.finite = step.finite && step.x.allFinite() && std::isfinite(step.max_increment);
  rec.max_increment_mm = step.max_increment;
  rec.pgs_iterations = step.pgs.iterations;
  rec.pgs_residual = step.pgs.residual;
  rec.pgs_stop = step.pgs.stop;
  rec.diagnosis = step.diagnosis;
  rec.inverted_elements = step.inverted_elements;
  state.seconds.free_motion += step.seconds_free_motion;
  state.seconds.delassus += step.seconds_delassus;
  state.seconds.pgs += step.seconds_pgs;
  state.seconds.correction += step.seconds_correction;
  return step;
}

/// A finite step kept: its λ for the next warm start and, where the stage keeps its system, W,
/// δ_free and the gaps at the start state for the noise model.
void keep_step(const LoopInputs& in, const StageOptions& stage, const ConstraintRows& rows,
               const std::vector<LambdaKey>& keys_of_rows, StepResult& step, LoopState& state) {
  state.warm.clear();
  for (index_t i = 0; i < rows.size(); ++i)
    state.warm[keys_of_rows[static_cast<std::size_t>(i)]] =
        step.lambda.size() ? step.lambda[i] : 0.0;
  if (!stage.keep_system) return;
  state.last_delassus = std::move(step.delassus);
  state.last_delta_free = std::move(step.delta_free);
  state.last_scale = step.compliance_scale;
  state.last_delta_start.resize(0);
  if (in.start_state.rows() == state.positions.rows()) {
    const MatrixX3d to_start = in.start_state - state.positions;
    state.last_delta_start.resize(rows.size());
    for (index_t i = 0; i < rows.size(); ++i)
      state.last_delta_start[i] =
          rows[i].violation + rows[i].direction.dot(rows[i].stencil.position(to_start));
  }
  state.last_vessel_rows.clear();
  state.last_vessel_features.clear();
  for (index_t i = 0; i < rows.size(); ++i)
    if (rows[i].set == ConstraintSet::VESSELS) {
      state.last_vessel_rows.push_back(i);
      state.last_vessel_features.push_back(rows[i].feature);
    }
}

/// Algorithm 1, step 5: whether the stage settled on this step `dx`; if not, the trust region's
/// update (into `rec.trust`, the loop's radius and damping). Returns the successive-steps test.
SuccessiveSteps trust_and_stop(const RegistrationOptions& options, const StageOptions& stage,
                               const MatrixX3d& dx, StageLoop& loop, IterationRecord& rec,
                               bool& settled) {
  // A damped step moves `damping` of the way: settled only when the undamped one is small too.
  const double tolerance = options.increment_tolerance_mm * loop.damping;
  const bool small = !rec.limited && rec.max_increment_mm < tolerance;
  // The pairs of this step and the previous one are the same ones: held, frozen, or fresh and
  // unchanged.
  const bool same_pairing =
      stage.kind == StageKind::HELD || !rec.pairing_changed || rec.pairing_frozen;
  settled = small && same_pairing;
  SuccessiveSteps steps;
  steps.limited = rec.limited;
  steps.same_damping = loop.previous_damping == loop.damping;
  steps.same_pairing = same_pairing;
  if (!settled && loop.previous_dx.size() > 0) {
    const double dot = (dx.array() * loop.previous_dx.array()).sum();
    const double previous_squared = loop.previous_dx.squaredNorm();
    const double denom = dx.norm() * std::sqrt(previous_squared);
    steps.cosine = denom > 0 ? dot / denom : 1.0;
    steps.projected_ratio = previous_squared > 0 ? dot / previous_squared : 0.0;
    // In the norm of the radius and of the stop test (max nodal |Δx|), so that the history's
    // max_increment_mm shows why the radius was held or halved.
    steps.length_ratio = loop.previous_increment > 0
                             ? rec.max_increment_mm / loop.previous_increment
                             : std::numeric_limits<double>::infinity();
  }
  if (!settled) rec.trust = trust_update(steps, loop.max_radius, loop.radius, loop.damping);
  loop.previous_dx = dx;
  loop.previous_increment = rec.max_increment_mm;
  loop.previous_damping = rec.damping;  // this step's, before any DAMP
  return steps;
}

/// TAIL: after a step `dx` whose contraction ratio agrees with the previous step's, the rest of
/// the geometric series at once (tail_jump_factor()), cut to the trust radius; into `state`, its
/// length into `rec`.
void take_tail(const SuccessiveSteps& steps, const MatrixX3d& dx, StageLoop& loop, LoopState& state,
               IterationRecord& rec) {
  const std::optional<double> ratio = tail_ratio(steps);
  const std::optional<double> factor = tail_jump_factor(loop.previous_tail_ratio, ratio);
  loop.previous_tail_ratio = ratio;
  if (!factor) return;
  MatrixX3d jump = *factor * dx;
  double length = jump.rowwise().norm().maxCoeff();
  if (!std::isfinite(length) || length == 0.0) return;
  if (length > loop.radius) {
    jump *= loop.radius / length;
    length = loop.radius;
  }
  state.positions += jump;
  rec.extrapolated_mm = length;
  // The next step answers the jump, not the map's own contraction: it is compared with nothing
  // (as a stage's first step is), and two fresh ratios come before another jump.
  loop.previous_dx.resize(0, 3);
  loop.previous_tail_ratio.reset();
}

/// The iteration's line of the debug log.
void log_iteration(const LoopState& state, const StageOptions& stage, const IterationRecord& rec,
                   const StepResult& step, const SuccessiveSteps& steps) {
  logger().debug(
      "registration iteration {} ({}): {} vessel + {} footprint pairs ({}), {} dura rows, {} "
      "rows, "
      "|dx| {:.4f} mm (uncut {:.4g}, damping {:.3g}), PGS {} ({} sweeps), trust {:.3g} mm {} "
      "(cosine {:.2f}, |dx| ratio {:.2f}, {} pairs)",
      state.history.size(), to_string(stage.kind), rec.vessel_pairs, rec.footprint_pairs,
      to_string(rec.pairing), rec.dura_rows, rec.rows, rec.max_increment_mm, step.uncut_increment,
      rec.damping, to_string(rec.pgs_stop), rec.pgs_iterations, rec.trust_radius_mm,
      to_string(rec.trust), steps.cosine.value_or(std::numeric_limits<double>::quiet_NaN()),
      steps.length_ratio, steps.same_pairing ? "same" : "new");
}

}  // namespace

StageRecord run_stage(const LoopInputs& in, const StageOptions& stage, LoopState& state) {
  const RegistrationOptions& options = *in.options;
  StageRecord record;
  record.kind = stage.kind;
  record.first_iteration = static_cast<int>(state.history.size()) + 1;
  record.vessel_compliance_ratio = stage.vessel_compliance_ratio;
  StepOptions step_options = options.step;
  step_options.compliance_ratio[static_cast<std::size_t>(ConstraintSet::VESSELS)] =
      stage.vessel_compliance_ratio;
  step_options.keep_system = stage.keep_system;
  step_options.rest = in.bulk_rest;
  StageLoop loop;
  loop.max_radius = options.step.max_increment > 0 ? options.step.max_increment
                                                   : std::numeric_limits<double>::infinity();
  loop.radius = loop.max_radius;

  int inverted_run = 0;  // consecutive steps that left elements inverted
  for (int it = 1; it <= stage.max_iterations; ++it) {
    const auto t_it = Clock::now();
    IterationRecord rec;
    rec.stage = stage.kind;
    rec.pairing_frozen = loop.frozen;
    rec.vessel_compliance_ratio = stage.vessel_compliance_ratio;
    pair_and_filter(in, stage, it, loop.frozen, state, rec);
    ConstraintRows rows;
    std::set<PairKey> keys = build_rows(in, state, rec, rows);
    state.seconds.pairing += seconds_since(t_it);

    const std::vector<LambdaKey> keys_of_rows = lambda_keys(rows);
    StepResult step = take_step(in, rows, keys_of_rows, loop, step_options, state, rec);
    rec.pairing_changed = loop.pair_sets.empty() || keys != loop.pair_sets.back();
    state.rows_by_set = rows.count_by_set();
    if (!rec.finite) {
      // A diverging iteration: keep the last finite iterate and its λ, and stop.
      if (rec.diagnosis.empty()) rec.diagnosis = "the step was not finite";
      rec.seconds = seconds_since(t_it);
      state.history.push_back(rec);
      record.iterations = it;
      record.stop = StageStop::DIVERGED;
      logger().warn("registration iteration {}: the step was not finite; stopping (diverged)",
                    state.history.size());
      return record;
    }
    keep_step(in, stage, rows, keys_of_rows, step, state);
    const MatrixX3d dx = step.x - state.positions;
    locate_increment(in.model->mesh(), dx, step.x, rec);
    state.positions = std::move(step.x);
    // A cycle of the pairing set (it changed, to one seen before): freeze it from now on.
    if (!loop.frozen && stage.kind != StageKind::HELD && rec.pairing_changed &&
        std::find(loop.pair_sets.begin(), loop.pair_sets.end(), keys) != loop.pair_sets.end()) {
      loop.frozen = true;
      logger().debug("registration iteration {}: pairing cycles between two sets; frozen",
                     state.history.size() + 1);
    }
    loop.pair_sets.push_back(std::move(keys));

    bool settled = false;
    const SuccessiveSteps steps = trust_and_stop(options, stage, dx, loop, rec, settled);
    // A clean step creeps on: its pairs and damping are the last step's, it is not cut, and it
    // does not turn back (GROW; a turn-back is the trust region's to damp or shrink).
    if (!steps.limited && steps.same_damping && steps.same_pairing &&
        rec.trust == TrustDecision::GROW)
      loop.clean_increments.push_back(rec.max_increment_mm);
    else
      loop.clean_increments.clear();
    if (!settled && options.extrapolate_tails && loop.radius >= options.increment_tolerance_mm)
      take_tail(steps, dx, loop, state, rec);
    if (rec.extrapolated_mm > 0.0) loop.clean_increments.clear();  // the next step answers it
    rec.seconds = seconds_since(t_it);
    state.history.push_back(rec);
    record.iterations = it;
    log_iteration(state, stage, rec, step, steps);
    if (settled) {
      record.stop = StageStop::SETTLED;
      break;
    }
    if (loop.radius < options.increment_tolerance_mm) {
      record.stop = StageStop::NOT_SETTLING;
      break;
    }
    inverted_run = rec.inverted_elements > 0 ? inverted_run + 1 : 0;
    if (stage.stop_when_stalled && inverted_run >= stall_window) {
      record.stop = StageStop::STALLED;
      logger().debug(
          "registration iteration {}: {} stage stalled ({} elements inverted on each "
          "of the last {} steps)",
          state.history.size(), to_string(stage.kind), rec.inverted_elements, stall_window);
      break;
    }
    if (stage.stop_when_stalled &&
        stage_stalled(loop.clean_increments, options.increment_tolerance_mm * rec.damping,
                      stage.max_iterations - it)) {
      record.stop = StageStop::STALLED;
      logger().debug(
          "registration iteration {}: {} stage stalled (|dx| {:.4f} -> {:.4f} mm over "
          "{} clean steps)",
          state.history.size(), to_string(stage.kind),
          loop.clean_increments[loop.clean_increments.size() - stall_window],
          loop.clean_increments.back(), stall_window);
      break;
    }
  }
  if (stage.kind == StageKind::HELD) state.held_pairs = state.vessel_pairs;
  return record;
}

bool stage_stalled(const std::vector<double>& clean_increments, double tolerance, int remaining) {
  const auto w = static_cast<std::size_t>(stall_window);
  if (clean_increments.size() < w) return false;
  const double first = clean_increments[clean_increments.size() - w];
  const double last = clean_increments.back();
  if (!(last > tolerance) || !(first > 0.0)) return false;  // settling, or nothing to read
  const double rate = std::pow(last / first, 1.0 / double(w - 1));
  if (!(rate < 1.0)) return true;
  return std::log(tolerance / last) / std::log(rate) > double(remaining);
}

void locate_increment(const core::TetMesh& mesh, const MatrixX3d& dx, const MatrixX3d& x,
                      IterationRecord& rec) {
  rec.max_increment_node = -1;
  rec.max_increment_share = 0.0;
  rec.increment_beyond_mm = 0.0;
  const double total = dx.squaredNorm();
  if (dx.rows() == 0 || !(total > 0.0) || !std::isfinite(total)) return;
  Eigen::Index node = 0;
  const Eigen::VectorXd length = dx.rowwise().norm();
  length.maxCoeff(&node);
  rec.max_increment_node = static_cast<index_t>(node);
  rec.max_increment_at = x.row(node).transpose();
  rec.max_increment_share = dx.row(node).squaredNorm() / total;
  std::vector<bool> near(static_cast<std::size_t>(dx.rows()), false);
  const MatrixX4i& tets = mesh.tets();
  for (Eigen::Index t = 0; t < tets.rows(); ++t)
    if ((tets.row(t).array() == static_cast<int>(node)).any())
      for (int k = 0; k < 4; ++k) near[static_cast<std::size_t>(tets(t, k))] = true;
  near[static_cast<std::size_t>(node)] = true;
  for (Eigen::Index i = 0; i < dx.rows(); ++i)
    if (!near[static_cast<std::size_t>(i)])
      rec.increment_beyond_mm = std::max(rec.increment_beyond_mm, length[i]);
}

std::string describe_increment(const IterationRecord& last) {
  if (last.max_increment_node < 0) return "";
  char buf[320];
  std::snprintf(buf, sizeof buf,
                "; the last step was largest at node %lld ((%.1f, %.1f, %.1f) mm, %.0f %% of its "
                "squared length, %lld elements inverted); beyond that node's elements the mesh "
                "moved at most %.3g mm",
                static_cast<long long>(last.max_increment_node), last.max_increment_at.x(),
                last.max_increment_at.y(), last.max_increment_at.z(),
                100.0 * last.max_increment_share, static_cast<long long>(last.inverted_elements),
                last.increment_beyond_mm);
  return buf;
}

ConstraintRows data_rows_at(const LoopInputs& in, const LoopState& state) {
  ConstraintRows rows;
  const RegistrationModel& model = *in.model;
  const core::TetMesh& mesh = model.mesh();
  if (in.vessels && !state.vessel_pairs.empty())
    add_vessel_rows(rows, state.vessel_pairs, model.skeleton(),
                    MappedVertices{&mesh, &model.skeleton_mapping()}, state.positions,
                    in.vessel_points);
  if (in.footprint && !state.footprint_pairs.empty())
    add_footprint_rows(rows, state.footprint_pairs, model.surface(),
                       MappedVertices{&mesh, &model.surface_mapping()}, state.positions,
                       in.footprint_points, in.footprint_normals);
  if (in.landmarks)
    add_landmark_rows(rows, MappedVertices{&mesh, &in.landmark_map}, state.positions,
                      in.landmark_targets);
  return rows;
}

}  // namespace brainshift::constraints
