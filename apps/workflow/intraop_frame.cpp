#include "apps/workflow/intraop_frame.hpp"

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

}  // namespace brainshift::workflow
