#include "constraints/registration/uncertainty.hpp"

#include <algorithm>
#include <cmath>

namespace brainshift::constraints {

Eigen::VectorXd tracking_variance(ConstRef<MatrixX3d> points, const Vector3d& centre,
                                  const UncertaintyOptions& uo) {
  // tr(h Σθ hᵀ), h = [I, −[x − c]×], Σθ = diag(σ_t²/3 I, σ_r²/3 I): σ_t² + σ_r²/3 · tr([d]×[d]×ᵀ),
  // tr([d]×[d]×ᵀ) = 2|d|².
  const double st2 = uo.tracking_translation_mm * uo.tracking_translation_mm;
  const double sr = uo.tracking_rotation_deg * M_PI / 180.0;
  const double k = 2.0 / 3.0 * sr * sr;
  Eigen::VectorXd v(points.rows());
  for (Eigen::Index i = 0; i < points.rows(); ++i)
    v[i] = st2 + k * (points.row(i).transpose() - centre).squaredNorm();
  return v;
}

Eigen::VectorXd confounded_pose_variance(const RegistrationModel& model,
                                         const RegistrationResult& r,
                                         const std::vector<index_t>& rows) {
  const index_t n = model.mesh().num_nodes();
  Eigen::VectorXd v = Eigen::VectorXd::Zero(n);
  if (rows.empty()) return v;
  const auto response_at = [&](index_t node) {
    return load_response_at(model.load_response(), node).norm();
  };
  // The load response's mean at the data rows' nodes (stencil weights sum to 1 per row).
  double reference = 0.0;
  for (const index_t i : rows) {
    const Stencil& st = r.data_rows[i].stencil;
    for (int k = 0; k < st.size; ++k)
      reference += st.weight[static_cast<std::size_t>(k)] *
                   response_at(st.node[static_cast<std::size_t>(k)]) /
                   static_cast<double>(rows.size());
  }
  if (!(reference > 0)) return v;
  const Eigen::Isometry3d to_intra = r.rigid.transform.inverse();
  for (index_t i = 0; i < n; ++i) {
    const Vector3d x = r.positions.row(i).transpose();
    const double rho = std::clamp(response_at(i) / reference, 0.0, 1.0);
    const double d = (to_intra * x - x).norm() * (1.0 - rho);
    v[i] = d * d;
  }
  return v;
}

}  // namespace brainshift::constraints
