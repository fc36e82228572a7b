#include "constraints/registration/noise/noise_model.hpp"

#include "core/error.hpp"

#include <Eigen/Eigenvalues>

#include <cmath>
#include <limits>

namespace brainshift::constraints {

std::string NoiseOptions::validate() const {
  if (!(min_ratio > 0) || !(max_ratio > min_ratio))
    return "noise model: need 0 < min_ratio < max_ratio";
  if (grid < 2) return "noise model: grid must be ≥ 2";
  if (!(change_factor >= 1)) return "noise model: change_factor must be ≥ 1";
  if (max_iterations < 1) return "noise model: max_iterations must be ≥ 1";
  if (max_rows < 8) return "noise model: max_rows must be ≥ 8";
  if (!(paired_test_z >= 0)) return "noise model: paired_test_z must be ≥ 0";
  if (!(paired_test_z_with_pose >= 0)) return "noise model: paired_test_z_with_pose must be ≥ 0";
  if (paired_test && !consider_start) return "noise model: the paired test needs consider_start";
  return {};
}

NoiseEstimate estimate_vessel_noise(const Eigen::MatrixXd& W, const Eigen::VectorXd& delta_free,
                                    const std::vector<index_t>& vessel_rows, double scale,
                                    double current_ratio, const NoiseOptions& options) {
  NoiseEstimate est;
  est.ratio = current_ratio;
  // Every k-th row pair when there are too many (GCV needs a representative sample, not all).
  const std::size_t stride = (vessel_rows.size() + static_cast<std::size_t>(options.max_rows) - 1) /
                             static_cast<std::size_t>(options.max_rows);
  std::vector<index_t> use;
  for (std::size_t i = 0; i < vessel_rows.size(); ++i)
    if ((i / 2) % std::max<std::size_t>(stride, 1) == 0) use.push_back(vessel_rows[i]);
  const auto m = static_cast<Eigen::Index>(use.size());
  est.rows = static_cast<index_t>(m);
  if (m < 8 || !(scale > 0) || W.rows() != delta_free.size()) {
    est.message =
        "noise model: " + std::to_string(m) + " vessel rows, too few to estimate the scatter";
    return est;
  }
  detail::VesselSpectrum sp;
  if (std::string why = detail::vessel_spectrum(W, delta_free, use, sp); !why.empty()) {
    est.message = "noise model: " + why;
    return est;
  }
  const Eigen::VectorXd& lam = sp.lam;
  const Eigen::VectorXd& z2 = sp.z2;
  double best = std::numeric_limits<double>::infinity();
  for (int k = 0; k < options.grid; ++k) {
    const double ratio = options.min_ratio * std::pow(options.max_ratio / options.min_ratio,
                                                      static_cast<double>(k) / (options.grid - 1));
    const double eps = ratio * scale;
    double rss = 0, trace = 0;
    for (Eigen::Index i = 0; i < m; ++i) {
      const double f = eps / (lam[i] + eps);  // shrinkage of eigencomponent i in the residual
      rss += f * f * z2[i];
      trace += f;
    }
    const double gcv = static_cast<double>(m) * rss / (trace * trace);
    if (gcv < best) {
      best = gcv;
      est.ratio = ratio;
      est.sigma_mm = std::sqrt(rss / trace);
      est.effective_dof = static_cast<double>(m) - trace;
    }
  }
  est.valid = std::isfinite(best);
  char buf[200];
  std::snprintf(buf, sizeof buf,
                "noise model (GCV on %lld vessel rows): compliance ratio %.3g, scatter %.2f mm, "
                "%.0f effective degrees of freedom",
                static_cast<long long>(m), est.ratio, est.sigma_mm, est.effective_dof);
  est.message = buf;
  return est;
}

namespace detail {

std::string vessel_spectrum(const Eigen::MatrixXd& W, const Eigen::VectorXd& delta_free,
                            const std::vector<index_t>& use, VesselSpectrum& out) {
  for (index_t r : use)
    if (r < 0 || r >= W.rows() || r >= delta_free.size()) return "vessel row index out of range";
  const auto m = static_cast<Eigen::Index>(use.size());
  Eigen::MatrixXd Wv(m, m);
  Eigen::VectorXd& y = out.y;
  y.resize(m);
  for (Eigen::Index a = 0; a < m; ++a) {
    y[a] = delta_free[use[static_cast<std::size_t>(a)]];
    for (Eigen::Index b = 0; b < m; ++b)
      Wv(a, b) = W(use[static_cast<std::size_t>(a)], use[static_cast<std::size_t>(b)]);
  }
  if (!Wv.allFinite() || !y.allFinite()) return "non-finite system";
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(Wv);
  if (es.info() != Eigen::Success) return "eigendecomposition failed";
  out.lam = es.eigenvalues().cwiseMax(0.0);
  out.Q = es.eigenvectors();
  out.z2 = (out.Q.transpose() * y).array().square();
  return "";
}

}  // namespace detail

}  // namespace brainshift::constraints
