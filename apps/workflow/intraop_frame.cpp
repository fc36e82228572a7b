#include "apps/workflow/intraop_frame.hpp"

#include "constraints/registration/start/global_start.hpp"

#include <algorithm>
#include <sstream>

namespace brainshift::workflow {

Eigen::Isometry3d intraop_from_model(const constraints::RegistrationResult& r) {
  return r.start.transform.inverse();
}

MatrixX3d to_intraop_frame(const constraints::RegistrationResult& r, ConstRef<MatrixX3d> points) {
  const Eigen::Isometry3d to_intra = intraop_from_model(r);
  MatrixX3d out(points.rows(), 3);
  for (Eigen::Index i = 0; i < points.rows(); ++i)
    out.row(i) = (to_intra * Vector3d(points.row(i).transpose())).transpose();
  return out;
}

FixedBaseMotion fixed_base_motion(const constraints::RegistrationResult& r,
                                  const constraints::RegistrationModel& model) {
  const Eigen::Isometry3d to_intra = intraop_from_model(r);
  const core::DofMap& dofs = model.mechanics().dofs();
  const MatrixX3d& rest = model.mesh().nodes();
  FixedBaseMotion m;
  double sum = 0.0;
  for (index_t n = 0; n < rest.rows(); ++n) {
    if (!dofs.is_fixed_node(n)) continue;
    const Vector3d X = rest.row(n).transpose();
    const double d = (to_intra * X - X).norm();
    sum += d;
    m.max_mm = std::max(m.max_mm, d);
    ++m.nodes;
  }
  if (m.nodes > 0) m.mean_mm = sum / double(m.nodes);
  return m;
}

double navigation_yardstick_mm(const constraints::RegistrationOptions& options) {
  const double stated = options.global_start.navigation_accuracy_mm;
  return stated > 0.0 ? stated : constraints::kResectNavigationAccuracyMm;
}

std::string fixed_base_note(const FixedBaseMotion& m, bool pose_given, double yardstick_mm) {
  if (pose_given || !(m.mean_mm > yardstick_mm)) return {};
  std::ostringstream os;
  os.setf(std::ios::fixed);
  os.precision(1);
  os << "the rigid pose moves the brain's fixed base (which does not move in surgery) by "
     << m.mean_mm << " mm on average (max " << m.max_mm << " mm), more than the navigation's "
     << "accuracy (" << yardstick_mm << " mm RMS): from one sweep the pose can take the sag and "
     << "tilt the whole brain; a pre-dura sweep (--pre-dura or --pre-dura-pose) measures the pose "
        "apart";
  return os.str();
}

}  // namespace brainshift::workflow
