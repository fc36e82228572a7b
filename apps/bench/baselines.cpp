#include "apps/bench/baselines.hpp"

#include "core/timing.hpp"

#include <chrono>
#include <cmath>
#include <map>
#include <utility>

namespace brainshift::workflow {
namespace {

using core::Clock;
using core::seconds_since;

}  // namespace

using constraints::ConstraintSet;
using constraints::RegistrationOptions;
using constraints::RegistrationResult;

/// The rigid start alone: no deformation.
RegistrationResult rigid_only(constraints::RegistrationModel& model,
                              const constraints::IntraopData& data,
                              const RegistrationOptions& options) {
  const auto t0 = Clock::now();
  RegistrationResult r;
  r.start = constraints::rigid_start(model, data, options);
  r.positions = model.mesh().nodes();
  r.displacement = MatrixX3d::Zero(r.positions.rows(), 3);
  r.converged = true;
  r.stop = constraints::RegistrationStop::CONVERGED;
  r.stop_reason = "rigid only";
  r.seconds.rigid = r.seconds.total = seconds_since(t0);
  return r;
}

/// The seeds' approach (prescribed displacements, a forward model): after the same rigid start,
/// each vessel point is assigned once to its nearest pre-operative skeleton point (within the
/// pairing distance); each skeleton point so chosen is displaced onto the mean of its points by
/// point-to-point rows (as soft as our vessel rows), and the corotational model is solved with
/// these displacements. No sliding along the vessels and no re-pairing.
RegistrationResult prescribed_displacement(constraints::RegistrationModel& model,
                                           const constraints::IntraopData& data,
                                           const RegistrationOptions& options) {
  const auto t0 = Clock::now();
  const constraints::StartResult rigid = options.start == constraints::RigidStart::RIGID
                                             ? constraints::rigid_start(model, data, options)
                                             : constraints::StartResult{};
  const double t_rigid = seconds_since(t0);
  const MatrixX3d& S = model.skeleton().points;
  std::map<index_t, std::pair<Vector3d, int>> sum;  // skeleton point → (Σ targets, count)
  for (Eigen::Index i = 0; i < data.vessel_points.rows(); ++i) {
    const Vector3d q = rigid.transform * Vector3d(data.vessel_points.row(i).transpose());
    Eigen::Index best = -1;
    const double d2 =
        S.rows() ? (S.rowwise() - q.transpose()).rowwise().squaredNorm().minCoeff(&best) : 0.0;
    if (best < 0 || std::sqrt(d2) > options.pair_max_distance_mm) continue;
    auto& [s, n] = sum.try_emplace(static_cast<index_t>(best), Vector3d::Zero(), 0).first->second;
    s += q;
    ++n;
  }
  constraints::IntraopData d;
  d.landmark_model_points.resize(static_cast<Eigen::Index>(sum.size()), 3);
  d.landmark_targets.resize(static_cast<Eigen::Index>(sum.size()), 3);
  Eigen::Index k = 0;
  for (const auto& [p, acc] : sum) {
    d.landmark_model_points.row(k) = S.row(p);
    d.landmark_targets.row(k++) = (acc.first / acc.second).transpose();
  }
  RegistrationOptions o = options;
  o.start = constraints::RigidStart::IDENTITY;
  o.use_vessels = o.use_footprint = false;
  o.use_landmarks = true;
  o.dura.mode = constraints::DuraOptions::Mode::NONE;
  const auto vessels = static_cast<std::size_t>(ConstraintSet::VESSELS);
  o.step.compliance_ratio[static_cast<std::size_t>(ConstraintSet::LANDMARK)] =
      o.step.compliance_ratio[vessels];
  RegistrationResult r = constraints::register_model(model, d, o);
  r.start = rigid;
  r.seconds.rigid = t_rigid;
  r.seconds.total = seconds_since(t0);
  return r;
}

}  // namespace brainshift::workflow
