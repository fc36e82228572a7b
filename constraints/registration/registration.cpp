#include "constraints/registration/registration.hpp"

#include "constraints/registration/loop/registration_stage.hpp"
#include "constraints/registration/noise/vessel_blocks.hpp"
#include "constraints/registration/pairing/pairing.hpp"
#include "constraints/registration/start/run_start.hpp"
#include "core/error.hpp"
#include "core/logger.hpp"
#include "core/timing.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

namespace brainshift::constraints {
namespace {

using detail::bulk_amplitude;
using detail::bulk_gravity;
using detail::run_start;
using detail::start_positions;
using detail::transformed;

using core::Clock;
using core::seconds_since;

MatrixX3d rotated(const Eigen::Isometry3d& T, ConstRef<MatrixX3d> n) {
  return n.rows() == 0 ? MatrixX3d(0, 3) : MatrixX3d(n * T.linear().transpose());
}

/// The tetrahedron a feature belongs to for subsampling: that of its first vertex.
template <typename Features>
std::vector<index_t> feature_tets(const Features& features, index_t count,
                                  const MappedVertices& mapped) {
  std::vector<index_t> t(static_cast<std::size_t>(count));
  for (index_t f = 0; f < count; ++f) t[static_cast<std::size_t>(f)] = mapped.tet(features(f));
  return t;
}

std::string no_data_reason(const IntraopData& d, const RegistrationModel& m,
                           const RegistrationOptions& o) {
  std::string why;
  auto add = [&why](const std::string& s) { why += (why.empty() ? "" : ", ") + s; };
  if (d.vessel_points.rows() == 0)
    add("no intra-operative vessel points");
  else if (!o.use_vessels)
    add("vessels disabled");
  else if (m.skeleton().segments.empty())
    add("no pre-operative skeleton");
  if (d.footprint_points.rows() == 0)
    add("no footprint points");
  else if (!o.use_footprint)
    add("footprint disabled");
  else if (m.surface().triangles.rows() == 0)
    add("no collision surface");
  return "nothing to register: " + why + "; the model was not moved";
}

}  // namespace

std::string RegistrationOptions::validate() const {
  if (!(pair_max_distance_mm > 0)) return "pair_max_distance_mm must be > 0";
  if (max_iterations < 1) return "max_iterations must be ≥ 1";
  if (!(increment_tolerance_mm > 0)) return "increment_tolerance_mm must be > 0";
  if (!(direction_radius_mm > 0)) return "direction_radius_mm must be > 0";
  if (auto e = global_start.validate(); !e.empty()) return e;
  if (shift_stage_iterations < 0) return "shift_stage_iterations must be ≥ 0";
  if (!(refine_pair_distance_mm > 0)) return "refine_pair_distance_mm must be > 0";
  if (auto e = vessel_filter.validate(); !e.empty()) return "vessel filter: " + e;
  if (auto e = footprint_filter.validate(); !e.empty()) return "footprint filter: " + e;
  if (auto e = dura.validate(); !e.empty()) return e;
  if (auto e = step.pgs.validate(); !e.empty()) return e;
  if (auto e = noise.validate(); !e.empty()) return e;
  if (min_vessel_pairs < 0) return "min_vessel_pairs must be ≥ 0";
  if (!(max_scatter_mm > 0)) return "max_scatter_mm must be > 0";
  if (auto e = uncertainty.validate(); !e.empty()) return e;
  for (double r : step.compliance_ratio)
    if (!(r >= 0)) return "compliance ratios must be ≥ 0";
  return {};
}

StepOptions RegistrationOptions::default_step() {
  StepOptions s;
  s.pgs.tolerance = 1e-4;
  s.pgs.max_iterations = 500;
  s.max_increment = 5.0;
  s.compliance_ratio[static_cast<std::size_t>(ConstraintSet::VESSELS)] = 0.2;
  s.compliance_ratio[static_cast<std::size_t>(ConstraintSet::DURA)] = 0.2;
  return s;
}

GlobalStartOptions RegistrationOptions::default_global_start() {
  GlobalStartOptions g;
  // Rigid plus the model's bulk response, the bulk shift bounded to a sag (bulk_sinks); the
  // noise model's "no deformation" is that state (NoiseOptions::start_is_bulk_state).
  g.bulk_response = true;
  return g;
}

FilterOptions RegistrationOptions::default_vessel_filter() {
  FilterOptions f;
  f.max_per_tet = 2;
  return f;
}

namespace {

/// The data in the model frame and the tables every stage reads.
LoopInputs loop_inputs(const RegistrationModel& model, const IntraopData& data,
                       const RegistrationOptions& options, const RegistrationResult& res,
                       const std::vector<Matrix3d>& shift_basis) {
  const core::TetMesh& mesh = model.mesh();
  LoopInputs in;
  in.model = &model;
  in.options = &options;
  in.vessels =
      options.use_vessels && data.vessel_points.rows() > 0 && !model.skeleton().segments.empty();
  in.footprint = options.use_footprint && data.footprint_points.rows() > 0 &&
                 model.surface().triangles.rows() > 0;
  in.landmarks = options.use_landmarks && data.landmark_targets.rows() > 0;
  in.pose_given = data.pose.has_value();
  in.dura = options.dura.mode != DuraOptions::Mode::NONE && model.rest_surface_index() != nullptr;
  const Eigen::Isometry3d& T = res.start.transform;
  in.vessel_points = transformed(T, data.vessel_points);
  if (res.start.bulk_accepted) {
    // Where each point was before the bulk shift: the HELD stage pairs there.
    in.held_pair_points = in.vessel_points;
    for (Eigen::Index i = 0; i < in.held_pair_points.rows(); ++i)
      in.held_pair_points.row(i) -=
          (shift_basis.empty()
               ? Vector3d(res.start.bulk_shift)
               : Vector3d(shift_basis[static_cast<std::size_t>(i)] * res.start.bulk_shift))
              .transpose();
  }
  in.footprint_points = transformed(T, data.footprint_points);
  in.footprint_normals = rotated(T, data.footprint_normals);
  in.landmark_targets = transformed(T, data.landmark_targets);
  if (in.landmarks) in.landmark_map = core::BarycentricMapping(mesh, data.landmark_model_points);
  if (in.vessels) in.directions = local_directions(in.vessel_points, options.direction_radius_mm);
  const MappedVertices skel{&mesh, &model.skeleton_mapping()};
  const MappedVertices surf{&mesh, &model.surface_mapping()};
  const auto& segs = model.skeleton().segments;
  const auto& tris = model.surface().triangles;
  in.segment_tets = feature_tets([&](index_t f) { return segs[static_cast<std::size_t>(f)][0]; },
                                 static_cast<index_t>(segs.size()), skel);
  in.triangle_tets =
      feature_tets([&](index_t f) { return tris(f, 0); }, static_cast<index_t>(tris.rows()), surf);
  if (in.vessels)
    in.segment_blocks = segment_blocks(model.skeleton(), options.noise.block_length_mm);
  return in;
}

RegistrationStop stop_of(StageStop s) {
  switch (s) {
    case StageStop::SETTLED:
      return RegistrationStop::CONVERGED;
    case StageStop::ITERATION_CAP:
      return RegistrationStop::MAX_ITERATIONS;
    case StageStop::STALLED:
    case StageStop::NOT_SETTLING:
      return RegistrationStop::NOT_SETTLING;
    case StageStop::DIVERGED:
      return RegistrationStop::DIVERGED;
  }
  BS_UNREACHABLE();
}

/// One line on why the registration stopped.
std::string stop_reason(const RegistrationResult& res, const RegistrationOptions& options,
                        const StageRecord& stage, const std::string& notes) {
  char buf[512];
  // The last step of the stage whose stop this is (a discarded SMOOTH stage's steps come after).
  const auto at = std::size_t(stage.first_iteration + stage.iterations - 2);
  const IterationRecord last = at < res.history.size() ? res.history[at] : IterationRecord{};
  int held = 0;
  for (const StageRecord& s : res.stages)
    if (s.kind == StageKind::HELD) held += s.iterations;
  switch (res.stop) {
    case RegistrationStop::NOT_SETTLING:
      std::snprintf(
          buf, sizeof buf,
          "not settling: the trust region shrank below %.3g mm after %d iterations (%s stage); the "
          "constraints cannot be met (inconsistent data or too large a shift); last PGS: %s",
          options.increment_tolerance_mm, res.iterations, to_string(last.stage).c_str(),
          to_string(last.pgs_stop).c_str());
      if (last.inverted_elements > 0)
        // What a node that flips back and forth usually is: an element the rows pulled through
        // itself (a vessel row's pull on one small element of a fine mesh).
        std::snprintf(buf + std::strlen(buf), sizeof buf - std::strlen(buf),
                      "; %lld elements inverted at the last step (the rows pull elements through "
                      "themselves: a compliance too stiff for this mesh, or wrong pairs)",
                      static_cast<long long>(last.inverted_elements));
      break;
    case RegistrationStop::DIVERGED:
      std::snprintf(buf, sizeof buf,
                    "diverged: the step of iteration %d (%s stage) was not finite (%s)",
                    res.iterations, to_string(last.stage).c_str(), last.diagnosis.c_str());
      break;
    case RegistrationStop::MAX_ITERATIONS:
      std::snprintf(buf, sizeof buf, "iteration cap %d reached (last increment %.3g mm)",
                    options.max_iterations, last.max_increment_mm);
      break;
    default:
      std::snprintf(buf, sizeof buf,
                    "increment below %.3g mm with a %s pairing set after %d iterations (%d on the "
                    "pairs of the bulk shift)",
                    options.increment_tolerance_mm,
                    last.pairing_frozen ? "frozen (it cycled)" : "stable", res.iterations, held);
  }
  std::string reason = buf;
  if (res.stop == RegistrationStop::NOT_SETTLING || res.stop == RegistrationStop::MAX_ITERATIONS)
    reason += describe_increment(last);  // where it did not settle: one node, or the mesh
  if (!notes.empty()) reason += "; " + notes;
  if (!res.start.bulk_message.empty()) reason += "; bulk shift: " + res.start.bulk_message;
  return reason;
}

/// register_model's argument checks: one clear error per problem.
void verify_registration_inputs(const core::TetMesh& mesh, const IntraopData& data,
                                const RegistrationResult& res) {
  BS_VERIFY(res.positions.rows() == mesh.num_nodes() && res.positions.allFinite(),
            "initial positions must be finite, one row per node (" << mesh.num_nodes() << ")");
  BS_VERIFY(data.vessel_points.allFinite() && data.footprint_points.allFinite() &&
                data.footprint_normals.allFinite() && data.landmark_targets.allFinite() &&
                data.landmark_model_points.allFinite(),
            "intra-operative points contain NaN or infinity");
  BS_VERIFY(data.footprint_normals.rows() == 0 ||
                data.footprint_normals.rows() == data.footprint_points.rows(),
            "footprint normals: " << data.footprint_normals.rows() << " for "
                                  << data.footprint_points.rows() << " points");
  BS_VERIFY(data.landmark_targets.rows() == data.landmark_model_points.rows(),
            "landmarks: " << data.landmark_model_points.rows() << " model points but "
                          << data.landmark_targets.rows() << " targets");
  BS_VERIFY(
      !data.pose ||
          (data.pose->matrix().allFinite() &&
           (data.pose->linear().transpose() * data.pose->linear() - Matrix3d::Identity()).norm() <
               1e-6 &&
           data.pose->linear().determinant() > 0),
      "the given pose must be a finite rotation and translation");
}

/// The schedule's first stages: HELD on the bulk shift's pairs (when the start accepted one),
/// then FREE with what is left of the iteration budget; returns the last stage run.
StageRecord run_held_and_free(const LoopInputs& in, const RegistrationOptions& options,
                              const RegistrationResult& res, double ratio0, LoopState& state) {
  int budget = options.max_iterations;
  StageRecord last;
  auto run = [&](const StageOptions& so) {
    last = run_stage(in, so, state);
    state.stages.push_back(last);
    budget -= last.iterations;
    return last;
  };
  if (res.start.bulk_accepted && options.shift_stage_iterations > 0) {
    StageOptions held;
    held.kind = StageKind::HELD;
    held.max_iterations = std::min(options.shift_stage_iterations, budget);
    held.vessel_compliance_ratio = ratio0;
    run(held);
  }
  if (last.stop != StageStop::DIVERGED && budget > 0) {
    StageOptions free;
    free.kind = StageKind::FREE;
    free.max_iterations = budget;
    free.pair_distance_mm =
        res.start.bulk_accepted ? options.refine_pair_distance_mm : options.pair_max_distance_mm;
    free.keep_held_pairs = res.start.bulk_accepted;
    free.vessel_compliance_ratio = ratio0;
    free.keep_system = in.vessels;  // for the noise model (its SMOOTH stage only when enabled)
    run(free);
  }
  return last;
}

/// After the FREE stage (settled, or ended without settling), the noise model: the vessel
/// compliance chosen on held-out branches, then the start kept (no compliance predicts held-out
/// vessels better than no deformation), a SMOOTH stage at the chosen compliance (its answer kept
/// only if it settles), or nothing. Returns the notes for the stop reason.
std::string choose_compliance_and_smooth(const LoopInputs& in, const RegistrationOptions& options,
                                         double ratio0, RegistrationResult& res, LoopState& state,
                                         StageRecord& last) {
  const core::TetMesh& mesh = in.model->mesh();
  std::string notes;
  const auto t0 = Clock::now();
  NoiseOptions noise = options.noise;
  if (in.pose_given) noise.paired_test_z = options.noise.paired_test_z_with_pose;
  if (options.noise.criterion == NoiseCriterion::BLOCK_CV) {
    std::vector<index_t> blocks;
    blocks.reserve(state.last_vessel_features.size());
    for (std::int64_t f : state.last_vessel_features)
      blocks.push_back(f >= 0 && static_cast<std::size_t>(f) < in.segment_blocks.size()
                           ? in.segment_blocks[static_cast<std::size_t>(f)]
                           : -1);
    res.noise = choose_vessel_compliance(
        state.last_delassus, state.last_delta_free, state.last_vessel_rows, blocks,
        state.last_scale, ratio0, noise, in.start_state.rows() ? &state.last_delta_start : nullptr);
  } else {
    res.noise = estimate_vessel_noise(state.last_delassus, state.last_delta_free,
                                      state.last_vessel_rows, state.last_scale, ratio0, noise);
  }
  state.seconds.noise += seconds_since(t0);
  notes = res.noise.message;
  const double change = res.noise.ratio / std::max(ratio0, 1e-300);
  if (options.noise.enabled && res.noise.valid && res.noise.keep_start) {
    // No compliance predicts held-out vessels better than no deformation: the model stays at
    // rest in the start's frame, or at the start's rigid + bulk state (ε → ∞). Recorded as a
    // SMOOTH stage of no iterations.
    state.positions = in.start_state.rows() ? in.start_state : mesh.nodes();
    state.warm.clear();
    StageRecord keep;
    keep.kind = StageKind::SMOOTH;
    keep.stop = StageStop::SETTLED;
    keep.first_iteration = static_cast<int>(state.history.size()) + 1;
    keep.iterations = 0;
    keep.vessel_compliance_ratio = std::numeric_limits<double>::infinity();
    state.stages.push_back(keep);
    last = keep;
    notes += "; the start is kept (no deformation)";
  } else if (options.noise.enabled && res.noise.valid &&
             res.noise.ratio <= options.noise.min_ratio * (1.0 + 1e-9)) {
    // No minimum inside the range (a shared error, which every branch predicts for the others,
    // as a tracking offset): the data did not choose a compliance; the free stage's stays.
    notes += "; the stiffest weighed, no minimum inside the range: the free stage's is kept";
  } else if (options.noise.enabled && res.noise.valid &&
             (change > options.noise.change_factor || change < 1.0 / options.noise.change_factor)) {
    LoopState settled = state;  // the FREE stage's answer, kept if smoothing does not settle
    StageOptions smooth;
    smooth.kind = StageKind::SMOOTH;
    smooth.max_iterations = options.noise.max_iterations;
    smooth.pair_distance_mm =
        res.start.bulk_accepted ? options.refine_pair_distance_mm : options.pair_max_distance_mm;
    smooth.keep_held_pairs = res.start.bulk_accepted;
    smooth.vessel_compliance_ratio = res.noise.ratio;
    smooth.stop_when_stalled = options.stop_stalled_smoothing;
    const StageRecord sm = run_stage(in, smooth, state);
    // A smoothing stage that settled with elements inverted (at the start of its last step, one
    // under the tolerance) folds the field where the free stage's answer did not: keep the latter.
    const bool free_unfolded =
        settled.history.empty() || settled.history.back().inverted_elements == 0;
    const index_t folded = sm.stop == StageStop::SETTLED && sm.iterations > 0 && free_unfolded
                               ? state.history.back().inverted_elements
                               : 0;
    if (sm.stop != StageStop::SETTLED || folded > 0) {
      settled.history = std::move(state.history);  // keep the record of what was tried
      settled.stages = state.stages;
      settled.seconds = state.seconds;
      state = std::move(settled);
      state.stages.push_back(sm);
      notes += folded > 0 ? "; the smoothing stage settled with " + std::to_string(folded) +
                                " elements inverted: the free stage's answer is kept"
                          : "; the smoothing stage ended " + to_string(sm.stop) +
                                ": the free stage's answer is kept";
      if (sm.stop == StageStop::DIVERGED) last = sm;  // a non-finite step never ends converged
    } else {
      state.stages.push_back(sm);
      last = sm;
    }
  }
  return notes;
}

/// The loop's answer into the result: positions, history, stages, rows, λ, times and stop.
void collect_result(const LoopInputs& in, const RegistrationOptions& options, double ratio0,
                    const StageRecord& last, const std::string& notes, LoopState& state,
                    RegistrationResult& res) {
  const core::TetMesh& mesh = in.model->mesh();
  res.positions = state.positions;
  res.displacement = res.positions - mesh.nodes();
  res.history = std::move(state.history);
  res.stages = std::move(state.stages);
  res.iterations = static_cast<int>(res.history.size());
  res.rows_by_set = state.rows_by_set;
  res.data_rows = data_rows_at(in, state);
  res.vessel_compliance_ratio = res.stages.empty() ? ratio0 : last.vessel_compliance_ratio;
  const double t_rigid = res.seconds.rigid;
  res.seconds = state.seconds;
  res.seconds.rigid = t_rigid;
  for (const auto& [k, l] : state.warm) res.lambda.emplace_back(k, l);
  res.stop = res.stages.empty() ? RegistrationStop::MAX_ITERATIONS : stop_of(last.stop);
  res.converged = res.stop == RegistrationStop::CONVERGED;
  res.stop_reason = stop_reason(res, options, last, notes);
}

/// Whether a converged answer can be trusted: vessels alone, too few or too scattered
/// (INSUFFICIENT_DATA); a pose searched on these points that they do not single out
/// (AMBIGUOUS_POSE).
void check_trust(const IntraopData& data, const RegistrationOptions& options, const LoopInputs& in,
                 const RegistrationResult* initial, RegistrationResult& res) {
  // Is the answer trustworthy? Vessels alone, too few or too scattered: say so (exit 2).
  if (res.converged && in.vessels && !in.footprint && !in.landmarks) {
    const index_t pairs = res.history.empty() ? 0 : res.history.back().vessel_pairs;
    std::string why;
    if (pairs < options.min_vessel_pairs)
      why = "only " + std::to_string(pairs) + " vessel points paired (of " +
            std::to_string(data.vessel_points.rows()) + "); at least " +
            std::to_string(options.min_vessel_pairs) + " are needed for a trustworthy registration";
    else if (res.noise.valid && res.noise.sigma_mm > options.max_scatter_mm)
      why = "the vessel points scatter by " + std::to_string(res.noise.sigma_mm) +
            " mm about the model, beyond " + std::to_string(options.max_scatter_mm) + " mm";
    if (!why.empty()) {
      res.converged = false;
      res.stop = RegistrationStop::INSUFFICIENT_DATA;
      res.stop_reason = "insufficient data: " + why + " (" + res.stop_reason + ")";
    }
  }
  // A pose searched on these points that the points do not single out: the answer is written
  // but not trusted (exit 2), so that a wrong pose is never reported as converged.
  if (res.converged && !initial && !data.pose && res.start.ambiguous) {
    res.converged = false;
    res.stop = RegistrationStop::AMBIGUOUS_POSE;
    res.stop_reason = "ambiguous pose: " + res.start.ambiguity + " (" + res.stop_reason + ")";
  }
}

/// An answer that cannot be trusted (diverged, insufficient data) returns the start's state,
/// never a half-deformed one.
void return_start_if_untrusted(const RegistrationModel& model, const IntraopData& data,
                               const RegistrationOptions& options,
                               const RegistrationResult* initial, LoopInputs& in, LoopState& state,
                               RegistrationResult& res) {
  const core::TetMesh& mesh = model.mesh();
  // Too few points to trust a deformation are too few to trust the bulk shift fitted jointly
  // with a pose to them: a cold start returns the rigid pose alone, fitted without the bulk
  // response (the rigid-only start), the model at rest in it. With a given pose (a pre-dura
  // sweep) the bulk shift is the only motion fitted to these points, and without it nothing
  // of the sag would be corrected (sparse_vessels seed 2: 7.0 mm against 2.35 with it), so the
  // start's state is kept.
  const bool rigid_fallback =
      res.stop == RegistrationStop::INSUFFICIENT_DATA && !initial && !data.pose && in.vessels;
  if (rigid_fallback) {
    detail::rigid_only_start(model, data, options, res);
    res.start.bulk_accepted = false;
    res.start.bulk_message = "not applied (insufficient data)";
    res.bulk_gravity.setZero();
    in = loop_inputs(model, data, options, res, {});  // no bulk load, no bulk rest
  }
  // A stop that cannot be trusted returns the start's state, never a half-deformed one.
  if (res.stop == RegistrationStop::DIVERGED || res.stop == RegistrationStop::INSUFFICIENT_DATA) {
    state.positions = start_positions(model, in, res, options, initial);
    state.warm.clear();
    res.positions = state.positions;
    res.displacement = res.positions - mesh.nodes();
    res.data_rows = data_rows_at(in, state);
    res.lambda.clear();
    res.start_returned = true;
    res.stop_reason += initial          ? "; the warm start's positions are returned"
                       : rigid_fallback ? "; the rigid pose alone is returned (no bulk shift, no "
                                          "deformation)"
                                        : "; the start's rigid + bulk state is returned (no "
                                          "deformation)";
  }
}

}  // namespace

RegistrationResult register_model(const RegistrationModel& model, const IntraopData& data,
                                  const RegistrationOptions& options,
                                  const RegistrationResult* initial) {
  const std::string invalid = options.validate();
  BS_VERIFY(invalid.empty(), "invalid registration options: " << invalid);
  const auto t_start = Clock::now();
  const core::TetMesh& mesh = model.mesh();
  RegistrationResult res;
  res.positions = initial ? initial->positions : mesh.nodes();
  verify_registration_inputs(mesh, data, res);

  const bool vessels =
      options.use_vessels && data.vessel_points.rows() > 0 && !model.skeleton().segments.empty();
  const bool footprint = options.use_footprint && data.footprint_points.rows() > 0 &&
                         model.surface().triangles.rows() > 0;
  const bool landmarks = options.use_landmarks && data.landmark_targets.rows() > 0;
  if (!vessels && !footprint && !landmarks) {
    res.displacement = res.positions - mesh.nodes();
    res.stop = RegistrationStop::NO_DATA;
    res.stop_reason = no_data_reason(data, model, options);
    res.seconds.total = seconds_since(t_start);
    return res;
  }

  // ---- The start (rigid start, bulk-shift search) ------------------------------------------
  std::vector<Matrix3d> shift_basis;
  run_start(model, data, options, initial, vessels, res, shift_basis);
  // ---- end of the start ----------------------------------------------------------------------

  LoopInputs in = loop_inputs(model, data, options, res, shift_basis);
  if (initial)
    in.bulk_gravity = initial->bulk_gravity;
  else if (options.bulk_as_load == BulkLoad::ON ||
           (options.bulk_as_load == BulkLoad::AUTO && data.pose))
    in.bulk_gravity = bulk_gravity(bulk_amplitude(model, in, res, options), options);
  double share = 1.0;  // of the bulk load carried as the rest (detail::bulk_rest())
  if (!in.bulk_gravity.isZero()) {
    in.bulk_rest = detail::bulk_rest(model, in.bulk_gravity, options, &share);
    in.bulk_gravity *= share;  // the load the rest carries (a warm start carries the same)
  }
  res.bulk_gravity = in.bulk_gravity;
  if (options.noise.enabled && options.noise.start_is_bulk_state && in.vessels)
    in.start_state = start_positions(model, in, res, options, initial);
  LoopState state;
  state.positions = res.positions;
  // Not where the whole load's response flattens or inverts an element (RestShape::degenerate,
  // or a share of the load carried): its nearly flat elements would be the first iterate, and the
  // rows' first pull inverts them; from the rest nodes the loop meets them gradually.
  if (options.start_at_load_rest && !initial && in.bulk_rest && in.bulk_rest->degenerate == 0 &&
      share == 1.0 && in.vessels && res.start.bulk_accepted && options.shift_stage_iterations > 0) {
    in.held_pairing_positions = state.positions;  // the HELD stage's pairs: as from the rest nodes
    state.positions = in.bulk_rest->nodes;        // the iterate: where the load's response is
  }
  if (initial)
    for (const auto& [k, l] : initial->lambda) state.warm[k] = l;

  // The schedule.
  const double ratio0 =
      options.step.compliance_ratio[static_cast<std::size_t>(ConstraintSet::VESSELS)];
  StageRecord last = run_held_and_free(in, options, res, ratio0, state);
  std::string notes;
  // The noise model also after a FREE stage that did not settle: the default compliance is a
  // prior, and where it pulls one small element of a fine mesh through itself (20k nodes: an
  // element inverted next to a vessel branch, a node flipping with it until the trust region
  // collapsed) the compliance the data choose may settle. SMOOTH's answer is kept only if it
  // settles; otherwise the stop stays the FREE stage's.
  if (in.vessels && last.kind == StageKind::FREE && last.stop != StageStop::DIVERGED) {
    const StageStop free_stop = last.stop;
    notes = choose_compliance_and_smooth(in, options, ratio0, res, state, last);
    if (free_stop != StageStop::SETTLED)
      notes = "the free stage ended " + to_string(free_stop) + "; " + notes;
  }

  collect_result(in, options, ratio0, last, notes, state, res);

  check_trust(data, options, in, initial, res);
  return_start_if_untrusted(model, data, options, initial, in, state, res);
  res.seconds.total = seconds_since(t_start);

  if (!initial && options.load_retry && !res.converged && !res.bulk_gravity.isZero() &&
      (res.stop == RegistrationStop::NOT_SETTLING ||
       res.stop == RegistrationStop::MAX_ITERATIONS)) {
    RegistrationOptions no_load = options;
    no_load.bulk_as_load = BulkLoad::OFF;
    RegistrationResult retry = register_model(model, data, no_load, nullptr);
    if (retry.converged) {
      retry.load_retry = true;
      std::string reason = "with the bulk shift carried as a load the loop ended ";
      reason += to_string(res.stop);
      reason += ", without it: ";
      reason += retry.stop_reason;
      retry.stop_reason = std::move(reason);
      retry.seconds.total += res.seconds.total;
      return retry;
    }
  }
  if (initial && options.cold_retry && !res.converged &&
      res.stop != RegistrationStop::INSUFFICIENT_DATA) {
    RegistrationResult cold = register_model(model, data, options, nullptr);
    if (cold.converged) {
      cold.cold_retry = true;
      cold.stop_reason =
          "warm start ended " + to_string(res.stop) + ", cold start: " + cold.stop_reason;
      cold.seconds.total += res.seconds.total;
      return cold;
    }
  }
  return res;
}

RegistrationResult start_only(const RegistrationModel& model, const IntraopData& data,
                              const RegistrationOptions& options) {
  const std::string invalid = options.validate();
  BS_VERIFY(invalid.empty(), "invalid registration options: " << invalid);
  BS_VERIFY(data.vessel_points.allFinite(), "intra-operative points contain NaN or infinity");
  const auto t_start = Clock::now();
  RegistrationResult res;
  res.positions = model.mesh().nodes();
  res.displacement = MatrixX3d::Zero(res.positions.rows(), 3);
  const bool vessels =
      options.use_vessels && data.vessel_points.rows() > 0 && !model.skeleton().segments.empty();
  if (!vessels) {
    res.stop = RegistrationStop::NO_DATA;
    res.stop_reason = "the start only: no vessel points";
    return res;
  }
  std::vector<Matrix3d> shift_basis;
  run_start(model, data, options, nullptr, vessels, res, shift_basis);
  const LoopInputs in = loop_inputs(model, data, options, res, shift_basis);
  res.positions = start_positions(model, in, res, options, nullptr);
  res.displacement = res.positions - model.mesh().nodes();
  res.converged = true;
  res.stop = RegistrationStop::CONVERGED;
  res.start_returned = true;
  res.stop_reason = std::string("the start only (rigid") +
                    (res.start.bulk_accepted ? " + bulk response)" : "; no bulk shift accepted)");
  res.seconds.total = seconds_since(t_start);
  return res;
}

}  // namespace brainshift::constraints
