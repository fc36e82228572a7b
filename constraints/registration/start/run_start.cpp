#include "constraints/registration/start/run_start.hpp"

#include "constraints/registration/start/global_start.hpp"
#include "core/error.hpp"
#include "core/logger.hpp"
#include "core/timing.hpp"

#include <cmath>

namespace brainshift::constraints {

StartResult pre_dura_pose(const RegistrationModel& model, ConstRef<MatrixX3d> vessel_points,
                          const RegistrationOptions& options) {
  GlobalStartOptions o = options.global_start;
  o.bulk_response = false;  // before the dura is opened the brain has not shifted
  return global_start(model.skeleton(), vessel_points, {}, o);
}

StartResult rigid_start(const RegistrationModel& model, const IntraopData& data,
                        const RegistrationOptions& options) {
  return pre_dura_pose(model, data.vessel_points, options);  // the same rigid-only start
}

namespace detail {

using core::Clock;
using core::seconds_since;

void rigid_only_start(const RegistrationModel& model, const IntraopData& data,
                      const RegistrationOptions& options, RegistrationResult& res) {
  res.start = pre_dura_pose(model, data.vessel_points, options);
}

/// The direction out of the brain at the craniotomy (model frame, unit): from the rest mesh's
/// centroid to the craniotomy's centre. Zero when the scene gives no craniotomy.
Vector3d outward_at_craniotomy(const core::TetMesh& mesh, const RegistrationOptions& options) {
  const Vector3d c = options.dura.craniotomy_centre;
  if (options.dura.craniotomy_radius_mm <= 0 && c.isZero()) return Vector3d::Zero();
  const Vector3d d = c - mesh.nodes().colwise().mean().transpose();
  return d.norm() > 0 ? Vector3d(d.normalized()) : Vector3d::Zero();
}

/// The start: the pose and the bulk shift, one StartResult. Inputs: the model, the data, the
/// options, the warm start (`initial`, may be null) and whether vessels are used; outputs:
/// res.start, res.seconds.rigid and the per-point basis of the bulk shift.
void run_start(const RegistrationModel& model, const IntraopData& data,
               const RegistrationOptions& options, const RegistrationResult* initial, bool vessels,
               RegistrationResult& res, std::vector<Matrix3d>& shift_basis) {
  const core::TetMesh& mesh = model.mesh();
  // Warm start: the previous frame's pose (its bulk shift is in its positions, not searched
  // again). A given pose (a pre-dura sweep) or the identity (start = identity): only the bulk
  // shift is searched, in that pose's frame (start_at_pose(), the bulk search). RIGID: the global
  // start — rigid pose plus the model's bulk response, found by an exhaustive search of the
  // distance map and refined by robust ICP, kept only when it scores better than the identity.
  BasisAt basis_at;
  if (options.shift_load_basis)
    basis_at = [&](ConstRef<MatrixX3d> x) { return load_basis(mesh, model.load_response(), x); };
  const auto t0 = Clock::now();
  if (initial) {
    res.start = initial->start;  // the pose and its origin (for the predicted error), not rerun
    res.start.bulk_accepted = false;
    res.start.bulk_message.clear();
    res.start.pose_given = res.start.pose_given || data.pose.has_value();
  } else if (data.pose) {
    res.start = start_at_pose(model.skeleton(), data.vessel_points, *data.pose, basis_at,
                              options.global_start, vessels,
                              "given pose (navigation offset measured before the dura was opened)");
    res.start.pose_given = true;
  } else if (options.start == RigidStart::RIGID && vessels) {
    res.start = global_start(model.skeleton(), data.vessel_points, basis_at, options.global_start,
                             outward_at_craniotomy(mesh, options));
    logger().debug("global start: {}", res.start.message);
  } else {
    res.start = start_at_pose(model.skeleton(), data.vessel_points, Eigen::Isometry3d::Identity(),
                              basis_at, options.global_start, vessels,
                              options.start == RigidStart::RIGID
                                  ? "identity (no vessel points for the global start)"
                                  : "identity (no rigid initialisation requested)");
  }
  if (res.start.bulk_accepted && options.shift_load_basis)
    shift_basis = load_basis(mesh, model.load_response(),
                             transformed(res.start.transform, data.vessel_points));
  res.seconds.rigid = seconds_since(t0);
}

/// The load amplitude a (per axis, in units of the 1 g loads of RegistrationModel::load_response)
/// whose response moves the vessel points by the start's bulk shift s on average: a = M⁻¹ s, with
/// M the mean response at the points' nearest nodes (load_basis()'s normalisation). Zero when no
/// bulk shift was accepted, without the load basis, or when M is singular.
Vector3d bulk_amplitude(const RegistrationModel& model, const LoopInputs& in,
                        const RegistrationResult& res, const RegistrationOptions& options) {
  if (!res.start.bulk_accepted || !res.start.bulk_shift.allFinite() || !options.shift_load_basis ||
      in.vessel_points.rows() == 0)
    return Vector3d::Zero();
  const Matrix3d mean = mean_load_response(model.mesh(), model.load_response(), in.vessel_points);
  if (!(std::abs(mean.determinant()) > 1e-9 * std::pow(mean.norm(), 3))) return Vector3d::Zero();
  const Vector3d a = mean.inverse() * res.start.bulk_shift;
  return a.allFinite() ? a : Vector3d::Zero();
}

/// The start's state: the rest nodes plus the bulk response to the start's
/// accepted bulk shift s, u_n = R_n a with R_n the node's load response (column k: axis k) and a
/// from bulk_amplitude() (so the vessel points see the shift the start found); a translation by s
/// without the load basis; the rest nodes when no bulk shift was accepted. A warm start's state
/// is its own positions.
MatrixX3d start_positions(const RegistrationModel& model, const LoopInputs& in,
                          const RegistrationResult& res, const RegistrationOptions& options,
                          const RegistrationResult* initial) {
  if (initial) return initial->positions;
  const core::TetMesh& mesh = model.mesh();
  MatrixX3d x = mesh.nodes();
  if (!res.start.bulk_accepted || !res.start.bulk_shift.allFinite()) return x;
  if (!options.shift_load_basis) return x.rowwise() + res.start.bulk_shift.transpose();
  const Vector3d a = bulk_amplitude(model, in, res, options);
  if (a.isZero()) return x;
  const auto& response = model.load_response();
  for (std::size_t k = 0; k < 3; ++k) x += a[static_cast<Eigen::Index>(k)] * response[k];
  return x.allFinite() ? x : MatrixX3d(mesh.nodes());
}

/// The body acceleration (mm/s²) of the bulk load: the load responses are to 1 g (9810 mm/s²)
/// at StepOptions' default density; scaled for the scene's density.
Vector3d bulk_gravity(const Vector3d& amplitude, const RegistrationOptions& options) {
  if (!(options.step.density > 0)) return Vector3d::Zero();  // massless: no body load can act
  return 9810.0 * amplitude * (StepOptions{}.density / options.step.density);
}

std::shared_ptr<const core::RestShape> bulk_rest(const RegistrationModel& model,
                                                 const Vector3d& gravity,
                                                 const RegistrationOptions& options,
                                                 double* share) {
  if (share != nullptr) *share = 1.0;
  const Vector3d one = bulk_gravity(Vector3d::Ones(), options);  // per unit amplitude
  if (!(one.array() > 0).all() || !gravity.allFinite()) return nullptr;
  MatrixX3d response = MatrixX3d::Zero(model.mesh().num_nodes(), 3);
  const auto& basis = model.load_response();
  for (std::size_t k = 0; k < 3; ++k) {
    const auto i = static_cast<Eigen::Index>(k);
    response += (gravity[i] / one[i]) * basis[k];
  }
  if (!response.allFinite()) return nullptr;
  const core::CorotationalModel& fem = model.mechanics().model();
  const MatrixX3d& nodes = model.mesh().nodes();
  auto rest = std::make_shared<core::RestShape>(fem.rest_shape(nodes + response));
  if (rest->degenerate == 0) return rest;
  // The largest share with no degenerate element: 12 halvings of [0, 1] (O(tets) each: a
  // millisecond at 100k tetrahedra).
  double lo = 0.0, hi = 1.0;
  for (int k = 0; k < 12; ++k) {
    const double mid = 0.5 * (lo + hi);
    (fem.rest_shape(nodes + mid * response).degenerate == 0 ? lo : hi) = mid;
  }
  if (lo > 0.0) {
    logger().warn(
        "bulk load: {} elements are flat or inverted in its response; carried as a rest: {:.3f} "
        "of it, under which none is (the vessel rows carry the rest)",
        rest->degenerate, lo);
    if (share != nullptr) *share = lo;
    return std::make_shared<core::RestShape>(fem.rest_shape(nodes + lo * response));
  }
  logger().warn(
      "bulk load: {} elements are flat or inverted in its response; they keep the mesh's rest",
      rest->degenerate);
  return rest;
}

}  // namespace detail

}  // namespace brainshift::constraints
