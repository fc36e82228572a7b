#include "constraints/registration/uncertainty/uncertainty.hpp"
#include "core/error.hpp"

#include <algorithm>
#include <cmath>

namespace brainshift::constraints {
namespace {

/// Regularised lower incomplete gamma P(a, x) (series below a + 1, continued fraction above).
double gamma_p(double a, double x) {
  if (!(x > 0)) return 0.0;
  const double lg = std::lgamma(a);
  if (x < a + 1.0) {
    double sum = 1.0 / a, term = sum;
    for (int n = 1; n < 1000 && std::abs(term) > 1e-15 * std::abs(sum); ++n)
      term *= x / (a + n), sum += term;
    return sum * std::exp(-x + a * std::log(x) - lg);
  }
  double b = x + 1.0 - a, c = 1e300, d = 1.0 / b, h = d;  // modified Lentz
  for (int i = 1; i < 1000; ++i) {
    const double an = -i * (i - a);
    b += 2.0;
    d = an * d + b;
    if (std::abs(d) < 1e-300) d = 1e-300;
    c = b + an / c;
    if (std::abs(c) < 1e-300) c = 1e-300;
    d = 1.0 / d;
    const double del = d * c;
    h *= del;
    if (std::abs(del - 1.0) < 1e-15) break;
  }
  return 1.0 - std::exp(-x + a * std::log(x) - lg) * h;
}

}  // namespace

double chi2_quantile(double k, double p) {
  BS_VERIFY(k > 0 && p > 0 && p < 1,
            "uncertainty: chi-square quantile of " << p << " with " << k << " degrees of freedom");
  double lo = 0.0, hi = k + 10.0 * std::sqrt(2.0 * k) + 10.0;
  for (int i = 0; i < 200; ++i) {  // bisection on P(k/2, x/2) = p
    const double mid = 0.5 * (lo + hi);
    (gamma_p(0.5 * k, 0.5 * mid) < p ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

const char* scale_estimator_name(const UncertaintyResult& u) {
  using SE = UncertaintyOptions::ScaleEstimator;
  switch (u.scale_estimator) {
    case SE::HELD_OUT:
    case SE::BY_POSE:
      return u.heldout_blocks > 0 ? "held_out_blocks" : "restricted";
    case SE::DISCREPANCY:
      return "discrepancy";
    case SE::MAXIMUM_LIKELIHOOD:
      break;
  }
  return "maximum_likelihood";
}

std::string UncertaintyOptions::validate() const {
  if (!(coarse_spacing_mm >= 0)) return "uncertainty: coarse_spacing_mm must be ≥ 0";
  if (!(hard_row_ratio > 0)) return "uncertainty: hard_row_ratio must be > 0";
  if (!(separated_mm >= 0)) return "uncertainty: separated_mm must be ≥ 0";
  if (!(no_data_median_mm > 0)) return "uncertainty: no_data_median_mm must be > 0";
  if (!(calibration > 0)) return "uncertainty: calibration must be > 0";
  if (!(scale_confidence >= 0 && scale_confidence < 1))
    return "uncertainty: scale_confidence must be in [0, 1)";
  if (solve_block < 1) return "uncertainty: solve_block must be ≥ 1";
  if (!(tracking_translation_mm >= 0) || !std::isfinite(tracking_translation_mm))
    return "uncertainty: tracking_translation_mm must be ≥ 0";
  if (!(tracking_rotation_deg >= 0) || !std::isfinite(tracking_rotation_deg))
    return "uncertainty: tracking_rotation_deg must be ≥ 0";
  return {};
}

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
  const Eigen::Isometry3d to_intra = r.start.transform.inverse();
  for (index_t i = 0; i < n; ++i) {
    const Vector3d x = r.positions.row(i).transpose();
    const double rho = std::clamp(response_at(i) / reference, 0.0, 1.0);
    const double d = (to_intra * x - x).norm() * (1.0 - rho);
    v[i] = d * d;
  }
  return v;
}

Eigen::VectorXd sigma_at(const core::TetMesh& mesh, const Eigen::VectorXd& node_variance,
                         ConstRef<MatrixX3d> points) {
  BS_VERIFY(node_variance.size() == mesh.num_nodes(),
            "uncertainty: " << node_variance.size() << " nodal variances for " << mesh.num_nodes()
                            << " nodes");
  core::MappingOptions o;
  o.max_outside_distance = 1e9;  // a landmark just outside the mesh takes its nearest tetrahedron
  const core::BarycentricMapping map(mesh, points, o);
  const Eigen::VectorXd v = map.matrix() * node_variance;
  return v.cwiseMax(0.0).cwiseSqrt();
}

}  // namespace brainshift::constraints
