#include "constraints/registration/registration.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>

#include <set>
#include <utility>

#include "constraints/registration/pairing.hpp"
#include "core/error.hpp"
#include "core/logger.hpp"

namespace brainshift::constraints {
namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

using PairKey = std::array<std::int64_t, 3>;  // (set, point, feature)
using LambdaKey = std::array<std::int64_t, 3>;  // (set, feature, row within the group)

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

std::vector<index_t> block_nodes_of(const core::TetMesh& mesh, const core::BarycentricMapping& a,
                                    const core::BarycentricMapping& b) {
  std::set<index_t> nodes;
  for (const auto* m : {&a, &b})
    for (index_t t : m->tet())
      for (int k = 0; k < 4; ++k) nodes.insert(mesh.tets()(t, k));
  return {nodes.begin(), nodes.end()};
}

MatrixX3d transformed(const Eigen::Isometry3d& T, ConstRef<MatrixX3d> p) {
  MatrixX3d out(p.rows(), 3);
  for (Eigen::Index i = 0; i < p.rows(); ++i) out.row(i) = (T * Vector3d(p.row(i).transpose())).transpose();
  return out;
}

MatrixX3d rotated(const Eigen::Isometry3d& T, ConstRef<MatrixX3d> n) {
  return n.rows() == 0 ? MatrixX3d(0, 3) : MatrixX3d(n * T.linear().transpose());
}

/// The pairs of one kind for this iteration: fresh (pair + filter) or frozen (same features).
std::vector<Pair> make_pairs(const FeatureIndex& index, ConstRef<MatrixX3d> points,
                             const std::vector<Pair>* frozen, const std::vector<Vector3d>& directions,
                             const std::vector<index_t>& tet_of_feature, double max_distance,
                             const FilterOptions& filter, FilterReport* report) {
  if (frozen) {
    std::vector<Pair> pairs;
    pairs.reserve(frozen->size());
    for (const Pair& f : *frozen) {
      Pair p = index.closest_on(f.feature, points.row(f.point).transpose());
      p.point = f.point;
      pairs.push_back(p);
    }
    return pairs;
  }
  std::vector<Pair> pairs = index.pair(points, max_distance);
  std::vector<index_t> tets;
  tets.reserve(pairs.size());
  for (const Pair& p : pairs) tets.push_back(tet_of_feature[static_cast<std::size_t>(p.feature)]);
  return filter_pairs(std::move(pairs), directions, tets, filter, report);
}

/// The tetrahedron a feature belongs to for subsampling: that of its first vertex.
template <typename Features>
std::vector<index_t> feature_tets(const Features& features, index_t count, const MappedVertices& mapped) {
  std::vector<index_t> t(static_cast<std::size_t>(count));
  for (index_t f = 0; f < count; ++f) t[static_cast<std::size_t>(f)] = mapped.tet(features(f));
  return t;
}

/// The segments of `s` with both ends within the bounding box of `points` enlarged by `margin`
/// (mm): the part of the pre-operative tree the probe can have seen. A rigid ICP against the
/// whole tree slides onto vessels outside the field of view (a dense cortical tree offers a
/// near-match every few millimetres).
Skeleton skeleton_near(const Skeleton& s, ConstRef<MatrixX3d> points, double margin) {
  if (points.rows() == 0) return s;
  const Vector3d lo = points.colwise().minCoeff().transpose().array() - margin;
  const Vector3d hi = points.colwise().maxCoeff().transpose().array() + margin;
  auto inside = [&](index_t i) {
    const Vector3d p = s.points.row(i).transpose();
    return (p.array() >= lo.array()).all() && (p.array() <= hi.array()).all();
  };
  Skeleton out = s;
  out.segments.clear();
  for (const auto& seg : s.segments)
    if (inside(seg[0]) && inside(seg[1])) out.segments.push_back(seg);
  return out.segments.empty() ? s : out;
}

/// Stage 2 after the bulk shift: a point that found no feature within the refinement distance
/// keeps the feature it was given in stage 1 (unless another point took that feature). Without
/// it, points drop out one after the other — the model relaxes towards the rest shape where it
/// loses rows, which moves more points out of reach — until nothing holds the shift.
void keep_held_pairs(std::vector<Pair>& pairs, const std::vector<Pair>& held, const FeatureIndex& index,
                     ConstRef<MatrixX3d> points) {
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
  std::sort(pairs.begin(), pairs.end(), [](const Pair& a, const Pair& b) { return a.point < b.point; });
}

std::string no_data_reason(const IntraopData& d, const RegistrationModel& m, const RegistrationOptions& o) {
  std::string why;
  auto add = [&why](const std::string& s) { why += (why.empty() ? "" : ", ") + s; };
  if (d.vessel_points.rows() == 0) add("no intra-operative vessel points");
  else if (!o.use_vessels) add("vessels disabled");
  else if (m.skeleton().segments.empty()) add("no pre-operative skeleton");
  if (d.footprint_points.rows() == 0) add("no footprint points");
  else if (!o.use_footprint) add("footprint disabled");
  else if (m.surface().triangles.rows() == 0) add("no collision surface");
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
  if (auto e = shift_search.validate(); !e.empty()) return e;
  if (auto e = vessel_filter.validate(); !e.empty()) return "vessel filter: " + e;
  if (auto e = footprint_filter.validate(); !e.empty()) return "footprint filter: " + e;
  if (auto e = dura.validate(); !e.empty()) return e;
  if (auto e = step.pgs.validate(); !e.empty()) return e;
  if (start == RigidStart::RIGID)
    if (auto e = rigid.validate(); !e.empty()) return "rigid: " + e;
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

FilterOptions RegistrationOptions::default_vessel_filter() {
  FilterOptions f;
  f.max_per_tet = 2;
  return f;
}

std::string to_string(RegistrationStop stop) {
  switch (stop) {
    case RegistrationStop::CONVERGED: return "converged";
    case RegistrationStop::MAX_ITERATIONS: return "max_iterations";
    case RegistrationStop::NO_DATA: return "no_data";
    case RegistrationStop::NOT_SETTLING: return "not_settling";
  }
  BS_UNREACHABLE();
}

RegistrationModel::RegistrationModel(const core::TetMesh& mesh, const std::vector<index_t>& fixed_nodes,
                                     Skeleton skeleton, SurfaceMesh surface, const ComplianceOptions& compliance)
    : m_skeleton(std::move(skeleton)), m_surface(std::move(surface)) {
  const auto t0 = Clock::now();
  m_skeleton_map = core::BarycentricMapping(mesh, m_skeleton.points);
  m_surface_map = core::BarycentricMapping(mesh, m_surface.vertices);
  if (m_surface.triangles.rows() > 0)
    m_rest_surface = std::make_unique<FeatureIndex>(FeatureIndex::triangles(m_surface.vertices, m_surface.triangles));
  m_rest_normals = vertex_normals(m_surface);
  m_mechanics = std::make_unique<ConstrainedModel>(mesh, fixed_nodes,
                                                   block_nodes_of(mesh, m_skeleton_map, m_surface_map), compliance);
  m_seconds_prepare = seconds_since(t0);
}

RegistrationModel::~RegistrationModel() = default;

const std::array<MatrixX3d, 3>& RegistrationModel::load_response() {
  if (!m_load_response) {
    const core::TetMesh& rest = mesh();
    StepOptions o;
    o.mechanics = Mechanics::LINEAR;
    std::array<MatrixX3d, 3> response;
    for (int k = 0; k < 3; ++k) {
      o.gravity = 9810.0 * Vector3d::Unit(k);
      response[static_cast<std::size_t>(k)] = m_mechanics->step(rest.nodes(), ConstraintRows{}, o).x - rest.nodes();
    }
    m_load_response = std::move(response);
  }
  return *m_load_response;
}

Stencil RegistrationModel::skeleton_stencil(index_t i) const { return MappedVertices{&mesh(), &m_skeleton_map}.stencil(i); }
Stencil RegistrationModel::surface_stencil(index_t i) const { return MappedVertices{&mesh(), &m_surface_map}.stencil(i); }

// ===== Start (issue 14 item 2; global_start.hpp) =====================================================

namespace {

/// The start's result as the loop's rigid start (`RegistrationResult::rigid`).
RigidInitResult as_rigid(const GlobalStartResult& g) {
  RigidInitResult r;
  r.transform = g.transform;
  r.converged = g.accepted;
  r.iterations = g.refine_iterations;
  r.stop_reason = "global start: " + g.message;
  r.rms_before_mm = g.rms_before_mm;
  r.rms_after_mm = g.rms_after_mm;
  r.pairs_used = g.pairs;
  return r;
}

/// The start's bulk shift as the loop's first-stage shift (`RegistrationResult::shift`).
ShiftSearchResult as_shift(const GlobalStartResult& g) {
  ShiftSearchResult s;
  s.shift = g.bulk_shift;
  s.accepted = g.bulk_accepted;
  s.score = g.score;
  s.score_zero = g.score_identity;
  s.message = g.bulk_accepted ? "from the global start" : "none from the global start";
  return s;
}

}  // namespace

RigidInitResult rigid_start(const RegistrationModel& model, const IntraopData& data, const RegistrationOptions& options) {
  GlobalStartOptions o = options.global_start;
  o.bulk_response = false;
  return as_rigid(global_start(model.skeleton(), data.vessel_points, {}, o));
}

RegistrationResult register_model(RegistrationModel& model, const IntraopData& data,
                                  const RegistrationOptions& options, const RegistrationResult* initial) {
  const std::string invalid = options.validate();
  BS_VERIFY(invalid.empty(), "invalid registration options: " << invalid);
  const auto t_start = Clock::now();
  const core::TetMesh& mesh = model.mesh();
  RegistrationResult res;
  res.positions = initial ? initial->positions : mesh.nodes();
  BS_VERIFY(res.positions.rows() == mesh.num_nodes() && res.positions.allFinite(),
            "initial positions must be finite, one row per node (" << mesh.num_nodes() << ")");
  BS_VERIFY(data.vessel_points.allFinite() && data.footprint_points.allFinite() &&
                data.footprint_normals.allFinite() && data.landmark_targets.allFinite() &&
                data.landmark_model_points.allFinite(),
            "intra-operative points contain NaN or infinity");
  BS_VERIFY(data.footprint_normals.rows() == 0 || data.footprint_normals.rows() == data.footprint_points.rows(),
            "footprint normals: " << data.footprint_normals.rows() << " for " << data.footprint_points.rows()
                                  << " points");
  BS_VERIFY(data.landmark_targets.rows() == data.landmark_model_points.rows(),
            "landmarks: " << data.landmark_model_points.rows() << " model points but "
                          << data.landmark_targets.rows() << " targets");

  const MappedVertices skel{&mesh, &model.skeleton_mapping()};
  const MappedVertices surf{&mesh, &model.surface_mapping()};
  const bool vessels = options.use_vessels && data.vessel_points.rows() > 0 && !model.skeleton().segments.empty();
  const bool footprint =
      options.use_footprint && data.footprint_points.rows() > 0 && model.surface().triangles.rows() > 0;
  const bool landmarks = options.use_landmarks && data.landmark_targets.rows() > 0;
  const bool dura = options.dura.mode != DuraOptions::Mode::NONE && model.rest_surface_index() != nullptr;
  if (!vessels && !footprint && !landmarks) {
    res.displacement = res.positions - mesh.nodes();
    res.stop = RegistrationStop::NO_DATA;
    res.stop_reason = no_data_reason(data, model, options);
    res.seconds.total = seconds_since(t_start);
    return res;
  }

  // ===== Start (issue 14 item 2): where the loop begins. ============================================
  // Warm start: the previous frame's pose. RIGID: the global start (global_start.hpp) — rigid pose
  // plus the model's bulk response, found by an exhaustive search of the distance map and refined
  // by robust ICP, kept only when it scores better than the identity. IDENTITY: no rigid part; the
  // bulk shift alone is searched (shift_search.hpp). Out: res.rigid (the transform into the model
  // frame), res.shift and shift_basis (the first stage's held pairs), res.start, res.seconds.rigid.
  std::vector<Matrix3d> shift_basis;
  const auto t_start_stage = Clock::now();
  if (initial) {
    res.rigid = initial->rigid;
  } else if (options.start == RigidStart::RIGID && vessels) {
    BasisAt basis_at;
    if (options.shift_load_basis)
      basis_at = [&](ConstRef<MatrixX3d> x) { return load_basis(mesh, model.load_response(), x); };
    res.start = global_start(model.skeleton(), data.vessel_points, basis_at, options.global_start);
    res.rigid = as_rigid(res.start);
    res.shift = as_shift(res.start);
    if (res.shift.accepted && options.shift_load_basis)
      shift_basis = load_basis(mesh, model.load_response(), transformed(res.rigid.transform, data.vessel_points));
    logger().debug("global start: {}", res.start.message);
  } else {
    res.rigid.converged = true;
    res.rigid.stop_reason = options.start == RigidStart::RIGID ? "identity (no vessel points for the global start)"
                                                              : "identity (no rigid initialisation requested)";
    if (vessels && options.shift_search.enabled) {
      const ShiftSearchOptions& so = options.shift_search;
      const MatrixX3d& pts = data.vessel_points;
      shift_basis = options.shift_load_basis ? load_basis(mesh, model.load_response(), pts) : std::vector<Matrix3d>{};
      res.shift = search_shift(skeleton_near(model.skeleton(), pts, so.radius_mm), pts, shift_basis, so);
      logger().debug("shift search: {}", res.shift.message);
    }
  }
  res.seconds.rigid = seconds_since(t_start_stage);
  // ===== End of the start. ==========================================================================
  const Eigen::Isometry3d& T = res.rigid.transform;
  const MatrixX3d vessel_pts = transformed(T, data.vessel_points);
  // Stage 1 (bulk shift accepted): pairs made at the shifted points, held until settled.
  bool shift_stage = res.shift.accepted;
  int shift_stage_end = 0;
  const MatrixX3d footprint_pts = transformed(T, data.footprint_points);
  const MatrixX3d footprint_nrm = rotated(T, data.footprint_normals);
  const MatrixX3d landmark_tgt = transformed(T, data.landmark_targets);
  const core::BarycentricMapping landmark_map =
      landmarks ? core::BarycentricMapping(mesh, data.landmark_model_points) : core::BarycentricMapping();
  const MappedVertices lmk{&mesh, &landmark_map};

  const std::vector<Vector3d> directions =
      vessels ? local_directions(vessel_pts, options.direction_radius_mm) : std::vector<Vector3d>{};
  const auto& segs = model.skeleton().segments;
  const auto& tris = model.surface().triangles;
  const std::vector<index_t> seg_tets =
      feature_tets([&](index_t f) { return segs[static_cast<std::size_t>(f)][0]; }, static_cast<index_t>(segs.size()), skel);
  const std::vector<index_t> tri_tets =
      feature_tets([&](index_t f) { return tris(f, 0); }, static_cast<index_t>(tris.rows()), surf);

  std::map<LambdaKey, double> warm;
  if (initial)
    for (const auto& [k, l] : initial->lambda) warm[k] = l;
  std::vector<std::set<PairKey>> pair_sets;  // per iteration
  std::vector<Pair> vessel_pairs, footprint_pairs, stage1_pairs;
  bool frozen = false;
  res.stop = RegistrationStop::MAX_ITERATIONS;
  const double max_radius =
      options.step.max_increment > 0 ? options.step.max_increment : std::numeric_limits<double>::infinity();
  double radius = max_radius;
  MatrixX3d previous_dx;  // the last step's increment, for the oscillation test
  StepOptions step_options = options.step;
  for (int it = 1; it <= options.max_iterations; ++it) {
    const auto t_it = Clock::now();
    IterationRecord rec;
    rec.pairing_frozen = frozen;
    ConstraintRows rows;
    std::set<PairKey> keys;
    if (vessels) {
      const FeatureIndex index = FeatureIndex::segments(model.skeleton_mapping().apply(res.positions), segs);
      if (shift_stage && it == 1) {
        // Stage 1: pairs made where each point was before the bulk shift; held from here on.
        MatrixX3d shifted = vessel_pts;
        for (Eigen::Index i = 0; i < shifted.rows(); ++i)
          shifted.row(i) -= shift_basis.empty() ? res.shift.shift.transpose()
                                                : Vector3d(shift_basis[static_cast<std::size_t>(i)] * res.shift.shift).transpose();
        vessel_pairs = make_pairs(index, shifted, nullptr, directions, seg_tets, options.pair_max_distance_mm,
                                  options.vessel_filter, &rec.vessel_filter);
      } else {
        const bool refine = res.shift.accepted && !shift_stage && !frozen;
        vessel_pairs = make_pairs(index, vessel_pts, (frozen || shift_stage) ? &vessel_pairs : nullptr, directions,
                                  seg_tets, refine ? options.refine_pair_distance_mm : options.pair_max_distance_mm,
                                  options.vessel_filter, &rec.vessel_filter);
        if (refine) keep_held_pairs(vessel_pairs, stage1_pairs, index, vessel_pts);
      }
      add_vessel_rows(rows, vessel_pairs, model.skeleton(), skel, res.positions, vessel_pts);
      for (const Pair& p : vessel_pairs) keys.insert({0, p.point, p.feature});
      rec.vessel_pairs = static_cast<index_t>(vessel_pairs.size());
    }
    std::vector<bool> touched;
    if (footprint) {
      const FeatureIndex index = FeatureIndex::triangles(model.surface_mapping().apply(res.positions), tris);
      footprint_pairs = make_pairs(index, footprint_pts, frozen ? &footprint_pairs : nullptr, {}, tri_tets,
                                   options.pair_max_distance_mm, options.footprint_filter, &rec.footprint_filter);
      add_footprint_rows(rows, footprint_pairs, model.surface(), surf, res.positions, footprint_pts, footprint_nrm);
      touched.assign(static_cast<std::size_t>(model.surface().vertices.rows()), false);
      for (const Pair& p : footprint_pairs) {
        keys.insert({1, p.point, p.feature});
        for (int k = 0; k < 3; ++k) touched[static_cast<std::size_t>(tris(p.feature, k))] = true;
      }
      rec.footprint_pairs = static_cast<index_t>(footprint_pairs.size());
    }
    if (dura)
      rec.dura_rows = add_dura_rows(rows, options.dura, model.surface(), *model.rest_surface_index(),
                                    model.rest_surface_normals(), surf,
                                    res.positions, touched);
    if (landmarks) {
      add_landmark_rows(rows, lmk, res.positions, landmark_tgt);
      rec.landmark_rows = 3 * static_cast<index_t>(landmark_tgt.rows());
    }
    rec.rows = rows.size();
    res.seconds.pairing += seconds_since(t_it);

    // Warm start keyed by (set, feature, row within the group), not by row index.
    const std::vector<LambdaKey> keys_of_rows = lambda_keys(rows);
    Eigen::VectorXd lambda0 = Eigen::VectorXd::Zero(rows.size());
    for (index_t i = 0; i < rows.size(); ++i)
      if (auto f = warm.find(keys_of_rows[static_cast<std::size_t>(i)]); f != warm.end()) lambda0[i] = f->second;
    step_options.max_increment = std::isfinite(radius) ? radius : 0.0;
    const StepResult step = model.mechanics().step(res.positions, rows, step_options, lambda0);
    rec.trust_radius_mm = step_options.max_increment;
    rec.limited = step.limited;
    warm.clear();
    for (index_t i = 0; i < rows.size(); ++i)
      warm[keys_of_rows[static_cast<std::size_t>(i)]] = step.lambda.size() ? step.lambda[i] : 0.0;
    const MatrixX3d dx = step.x - res.positions;
    res.positions = step.x;
    res.seconds.free_motion += step.seconds_free_motion;
    res.seconds.delassus += step.seconds_delassus;
    res.seconds.pgs += step.seconds_pgs;
    res.seconds.correction += step.seconds_correction;
    rec.max_increment_mm = step.max_increment;
    rec.pgs_iterations = step.pgs.iterations;
    rec.pgs_residual = step.pgs.residual;
    rec.pgs_stop = to_string(step.pgs.stop);
    rec.diagnosis = step.diagnosis;
    rec.pairing_changed = pair_sets.empty() || keys != pair_sets.back();
    // A cycle of the pairing set (it changed, to one seen before): freeze it from now on.
    if (!frozen && rec.pairing_changed && std::find(pair_sets.begin(), pair_sets.end(), keys) != pair_sets.end()) {
      frozen = true;
      logger().debug("registration iteration {}: pairing cycles between two sets; frozen", it);
    }
    pair_sets.push_back(std::move(keys));
    rec.seconds = seconds_since(t_it);
    res.history.push_back(rec);
    res.rows_by_set = rows.count_by_set();
    res.iterations = it;
    logger().debug("registration iteration {}: {} vessel + {} footprint pairs, {} dura rows, {} rows, |dx| {:.4f} mm, "
                   "PGS {} ({} sweeps){}",
                   it, rec.vessel_pairs, rec.footprint_pairs, rec.dura_rows, rec.rows, rec.max_increment_mm,
                   rec.pgs_stop, rec.pgs_iterations, rec.pairing_frozen ? ", pairs frozen" : "");
    if (!shift_stage && !step.limited && rec.max_increment_mm < options.increment_tolerance_mm &&
        (!rec.pairing_changed || rec.pairing_frozen)) {
      res.converged = true;
      res.stop = RegistrationStop::CONVERGED;
      break;
    }
    // Trust region: halve it when the step turns back on the previous one (oscillation: the
    // cosine of successive increments is negative), grow it back otherwise. A long shift reached
    // by several limited steps in the same direction keeps its radius.
    if (previous_dx.size() > 0) {
      const double denom = dx.norm() * previous_dx.norm();
      const double cosine = denom > 0 ? (dx.array() * previous_dx.array()).sum() / denom : 1.0;
      if (cosine < 0.0) radius *= 0.5;
      else radius = std::min(max_radius, 1.5 * radius);
    }
    previous_dx = dx;
    // Stage 1 ends when its held pairs have settled (or at its cap, or when its trust region
    // collapses): free pairing from here, with a fresh trust region and cycle history.
    if (shift_stage && ((!step.limited && rec.max_increment_mm < options.increment_tolerance_mm) ||
                        it >= options.shift_stage_iterations || radius < options.increment_tolerance_mm)) {
      shift_stage = false;
      shift_stage_end = it;
      stage1_pairs = vessel_pairs;
      pair_sets.clear();
      previous_dx.resize(0, 3);
      radius = max_radius;
      continue;
    }
    if (radius < options.increment_tolerance_mm) {
      res.stop = RegistrationStop::NOT_SETTLING;
      break;
    }
  }
  res.displacement = res.positions - mesh.nodes();
  for (const auto& [k, l] : warm) res.lambda.emplace_back(k, l);
  char buf[256];
  if (res.stop == RegistrationStop::NOT_SETTLING)
    std::snprintf(buf, sizeof buf,
                  "not settling: the trust region shrank below %.3g mm after %d iterations; the constraints "
                  "cannot be met (inconsistent data or too large a shift); last PGS: %s",
                  options.increment_tolerance_mm, res.iterations, res.history.back().pgs_stop.c_str());
  else if (res.converged)
    std::snprintf(buf, sizeof buf, "increment below %.3g mm with a %s pairing set after %d iterations (%d on the "
                  "pairs of the bulk shift)",
                  options.increment_tolerance_mm, frozen ? "frozen (it cycled)" : "stable", res.iterations,
                  shift_stage_end);
  else
    std::snprintf(buf, sizeof buf, "iteration cap %d reached (last increment %.3g mm)", options.max_iterations,
                  res.history.empty() ? 0.0 : res.history.back().max_increment_mm);
  res.stop_reason = buf;
  if (!res.shift.message.empty()) res.stop_reason += "; bulk shift: " + res.shift.message;
  res.seconds.total = seconds_since(t_start);
  return res;
}

}  // namespace brainshift::constraints
