// Block cross-validation of the vessel rows' compliance (noise_model.hpp, "Block
// cross-validation").
#include "constraints/registration/noise/noise_model.hpp"
#include "core/error.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>

namespace brainshift::constraints {

std::string to_string(NoiseCriterion c) {
  return core::enum_to_string(c);  // the option table's names (visit_fields)
}

Eigen::VectorXd block_loo_residuals(const Eigen::VectorXd& lambda, const Eigen::MatrixXd& Q,
                                    const Eigen::VectorXd& y,
                                    const std::vector<std::vector<Eigen::Index>>& blocks,
                                    double eps) {
  const Eigen::Index m = y.size();
  const Eigen::ArrayXd f = eps / (lambda.array().max(0.0) + eps);  // eigenvalues of I − A
  const Eigen::VectorXd r = Q * (f * (Q.transpose() * y).array()).matrix();
  Eigen::VectorXd e = Eigen::VectorXd::Constant(m, std::numeric_limits<double>::quiet_NaN());
  for (const auto& b : blocks) {
    const auto nb = static_cast<Eigen::Index>(b.size());
    if (nb == 0) continue;
    Eigen::MatrixXd QB(nb, m);
    Eigen::VectorXd rB(nb);
    for (Eigen::Index k = 0; k < nb; ++k) {
      QB.row(k) = Q.row(b[static_cast<std::size_t>(k)]);
      rB[k] = r[b[static_cast<std::size_t>(k)]];
    }
    // (I − A)_BB = Q_B diag(f) Q_Bᵀ: a principal block of a positive definite matrix (ε > 0).
    const Eigen::MatrixXd M = QB * f.matrix().asDiagonal() * QB.transpose();
    const Eigen::LDLT<Eigen::MatrixXd> ldlt(M);
    const Eigen::VectorXd eB = ldlt.solve(rB);
    for (Eigen::Index k = 0; k < nb; ++k) e[b[static_cast<std::size_t>(k)]] = eB[k];
  }
  return e;
}

namespace {

/// The CV scores of the candidate compliances: per candidate, per block, ‖e_B‖² of the
/// block-held-out residuals (the finite grid; then ε → ∞ when the start is considered).
struct CvScores {
  std::vector<double> ratios, eps_of;
  std::vector<std::vector<double>> scores;
  std::size_t finite_candidates = 0;
  /// Candidate k's mean held-out error² per row.
  [[nodiscard]] double total(std::size_t k, double md) const {
    double t = 0;
    for (double v : scores[k]) t += v;
    return t / md;
  }
};

/// The finite grid of compliance ratios scored by block cross-validation; GCV's scatter at its
/// own choice into est.sigma_mm (for the refusal test).
CvScores score_grid(const detail::VesselSpectrum& sp,
                    const std::vector<std::vector<Eigen::Index>>& blocks, double scale,
                    const NoiseOptions& options, NoiseEstimate& est) {
  const Eigen::VectorXd& y = sp.y;
  const Eigen::VectorXd& lam = sp.lam;
  const Eigen::MatrixXd& Q = sp.Q;
  const Eigen::VectorXd& z2 = sp.z2;
  const auto m = y.size();
  const double md = static_cast<double>(m);
  const auto nb = blocks.size();
  CvScores cv;
  std::vector<double>&ratios = cv.ratios, &eps_of = cv.eps_of;
  std::vector<std::vector<double>>& scores = cv.scores;
  double best_gcv = std::numeric_limits<double>::infinity();
  for (int k = 0; k < options.grid; ++k) {
    const double ratio = options.min_ratio * std::pow(options.max_ratio / options.min_ratio,
                                                      static_cast<double>(k) / (options.grid - 1));
    const double eps = ratio * scale;
    double rss = 0, trace = 0;
    for (Eigen::Index i = 0; i < m; ++i) {
      const double f = eps / (lam[i] + eps);
      rss += f * f * z2[i];
      trace += f;
    }
    // The scatter: GCV's σ̂ at GCV's own choice (as estimate_vessel_noise), for the refusal test.
    if (const double gcv = md * rss / (trace * trace); gcv < best_gcv) {
      best_gcv = gcv;
      est.sigma_mm = std::sqrt(rss / trace);
    }
    const Eigen::VectorXd e = block_loo_residuals(lam, Q, y, blocks, eps);
    std::vector<double> s(nb, 0.0);
    for (std::size_t b = 0; b < nb; ++b)
      for (Eigen::Index i : blocks[b]) s[b] += e[i] * e[i];
    ratios.push_back(ratio);
    eps_of.push_back(eps);
    scores.push_back(std::move(s));
  }
  cv.finite_candidates = scores.size();
  return cv;
}

/// One-standard-error rule (Hastie, Tibshirani & Friedman, ESL §7.10): the smoothest candidate
/// (largest ε, ε → ∞ included) whose CV exceeds the minimum by no more than the standard error of
/// that difference, estimated from the B paired per-block differences: a finite sample of
/// vessels cannot tell such candidates apart, and the smoother one deforms less on noise.
std::size_t one_standard_error(const CvScores& cv, std::size_t best, double md,
                               const NoiseOptions& options) {
  const std::vector<std::vector<double>>& scores = cv.scores;
  const std::size_t nb = scores.empty() ? 0 : scores.front().size();
  const auto total = [&](std::size_t k) { return cv.total(k, md); };
  std::size_t chosen = best;
  if (options.one_standard_error && nb >= 2)
    for (std::size_t k = scores.size(); k-- > best + 1;) {
      double mean = 0, sq = 0;
      for (std::size_t b = 0; b < nb; ++b) mean += scores[k][b] - scores[best][b];
      mean /= static_cast<double>(nb);
      for (std::size_t b = 0; b < nb; ++b) sq += std::pow(scores[k][b] - scores[best][b] - mean, 2);
      const double se = std::sqrt(sq / static_cast<double>(nb - 1) / static_cast<double>(nb));
      if (std::isfinite(total(k)) && mean <= se) {
        chosen = k;
        break;
      }
    }
  return chosen;
}

/// The paired test: deform (at the best finite candidate, or the one-SE rule's among the finite
/// ones) only if it beats ε → ∞ on the held-out blocks by more than z standard errors of the
/// mean per-block gain; otherwise keep the start. Returns the candidate chosen.
std::size_t paired_test(const CvScores& cv, std::size_t chosen, double md,
                        const NoiseOptions& options, NoiseEstimate& est) {
  const std::vector<std::vector<double>>& scores = cv.scores;
  const std::vector<double>& eps_of = cv.eps_of;
  const std::size_t finite_candidates = cv.finite_candidates;
  const std::size_t nb = scores.empty() ? 0 : scores.front().size();
  const auto total = [&](std::size_t k) { return cv.total(k, md); };
  if (options.paired_test && options.consider_start && nb >= 2 &&
      scores.size() == finite_candidates + 1) {
    std::size_t best_finite = finite_candidates;
    for (std::size_t k = 0; k < finite_candidates; ++k)
      if (std::isfinite(total(k)) &&
          (best_finite == finite_candidates || total(k) < total(best_finite)))
        best_finite = k;
    const std::size_t start = finite_candidates;
    double mean = 0, sq = 0;
    if (best_finite < finite_candidates) {
      for (std::size_t b = 0; b < nb; ++b) mean += scores[start][b] - scores[best_finite][b];
      mean /= static_cast<double>(nb);
      for (std::size_t b = 0; b < nb; ++b)
        sq += std::pow(scores[start][b] - scores[best_finite][b] - mean, 2);
    }
    const double se = std::sqrt(sq / static_cast<double>(nb - 1) / static_cast<double>(nb));
    // Per row (mm²), as CV itself: the per-block sums are over ~m/B rows.
    est.paired_gain_mm2 = mean * static_cast<double>(nb) / md;
    est.paired_se_mm2 = se * static_cast<double>(nb) / md;
    const bool deform =
        best_finite < finite_candidates && std::isfinite(mean) && mean > options.paired_test_z * se;
    if (!deform) {
      chosen = start;
    } else if (!std::isfinite(eps_of[chosen])) {
      chosen = best_finite;  // the one-SE rule went to ε → ∞, which the test rejected
    }
  }
  return chosen;
}

/// The estimate's message: the choice, the held-out errors, the scatter and the paired test.
std::string describe(const NoiseEstimate& est, Eigen::Index m, const NoiseOptions& options) {
  std::string message;
  char buf[300];
  if (est.keep_start)
    std::snprintf(buf, sizeof buf,
                  "noise model (block CV, %lld vessel rows in %lld branches): no deformation "
                  "(held-out error %.2f mm "
                  "per row, best compliance %.2f, not significantly better); scatter %.2f mm",
                  static_cast<long long>(m), static_cast<long long>(est.blocks),
                  est.cv_start_rms_mm, est.cv_best_rms_mm, est.sigma_mm);
  else
    std::snprintf(buf, sizeof buf,
                  "noise model (block CV, %lld vessel rows in %lld branches): compliance ratio "
                  "%.3g (held-out error "
                  "%.2f mm per row, best %.2f, %.2f without deformation), scatter %.2f mm, %.0f "
                  "effective degrees of "
                  "freedom",
                  static_cast<long long>(m), static_cast<long long>(est.blocks), est.ratio,
                  est.cv_rms_mm, est.cv_best_rms_mm, est.cv_start_rms_mm, est.sigma_mm,
                  est.effective_dof);
  message = buf;
  if (options.paired_test) {
    std::snprintf(buf, sizeof buf,
                  "; paired test: deformation gains %.3f ± %.3f mm² per row on held-out branches "
                  "(z %.2g)",
                  est.paired_gain_mm2, est.paired_se_mm2, options.paired_test_z);
    message += buf;
  }
  return message;
}

}  // namespace

NoiseEstimate choose_vessel_compliance(const Eigen::MatrixXd& W, const Eigen::VectorXd& delta_free,
                                       const std::vector<index_t>& vessel_rows,
                                       const std::vector<index_t>& row_blocks, double scale,
                                       double current_ratio, const NoiseOptions& options,
                                       const Eigen::VectorXd* delta_start) {
  NoiseEstimate est;
  est.ratio = current_ratio;
  est.criterion = NoiseCriterion::BLOCK_CV;
  if (row_blocks.size() != vessel_rows.size()) {
    est.message = "noise model: one block id per vessel row is needed";
    return est;
  }
  // Every k-th row pair when there are too many (as estimate_vessel_noise).
  const std::size_t stride = std::max<std::size_t>(
      1, (vessel_rows.size() + static_cast<std::size_t>(options.max_rows) - 1) /
             static_cast<std::size_t>(options.max_rows));
  std::vector<index_t> use;
  std::map<index_t, std::vector<Eigen::Index>> by_block;
  for (std::size_t i = 0; i < vessel_rows.size(); ++i)
    if ((i / 2) % stride == 0) {
      by_block[row_blocks[i]].push_back(static_cast<Eigen::Index>(use.size()));
      use.push_back(vessel_rows[i]);
    }
  const auto m = static_cast<Eigen::Index>(use.size());
  est.rows = static_cast<index_t>(m);
  est.blocks = static_cast<index_t>(by_block.size());
  if (m < 8 || by_block.size() < 2 || !(scale > 0) || W.rows() != delta_free.size() ||
      W.cols() != W.rows()) {
    est.message = "noise model: " + std::to_string(m) + " vessel rows in " +
                  std::to_string(by_block.size()) + " blocks, too few to cross-validate";
    return est;
  }
  detail::VesselSpectrum sp;
  if (std::string why = detail::vessel_spectrum(W, delta_free, use, sp); !why.empty()) {
    est.message = "noise model: " + why;
    return est;
  }
  const Eigen::VectorXd& y = sp.y;
  const Eigen::VectorXd& lam = sp.lam;
  std::vector<std::vector<Eigen::Index>> blocks;
  blocks.reserve(by_block.size());
  for (auto& [id, rows] : by_block) blocks.push_back(std::move(rows));

  const double md = static_cast<double>(m);
  const auto nb = blocks.size();
  CvScores cv = score_grid(sp, blocks, scale, options, est);
  std::vector<double>&ratios = cv.ratios, &eps_of = cv.eps_of;
  std::vector<std::vector<double>>& scores = cv.scores;
  // ε → ∞: the rows' gaps at the start's state (delta_start) or at the free motion (y).
  Eigen::VectorXd y_start = y;
  if (delta_start && delta_start->size() == delta_free.size() && delta_start->allFinite())
    for (Eigen::Index i = 0; i < m; ++i) y_start[i] = (*delta_start)[use[std::size_t(i)]];
  if (options.consider_start) {
    std::vector<double> s(nb, 0.0);
    for (std::size_t b = 0; b < nb; ++b)
      for (Eigen::Index i : blocks[b]) s[b] += y_start[i] * y_start[i];
    ratios.push_back(std::numeric_limits<double>::infinity());
    eps_of.push_back(std::numeric_limits<double>::infinity());
    scores.push_back(std::move(s));
  }
  est.cv_start_rms_mm = std::sqrt(y_start.squaredNorm() / md);
  const auto total = [&](std::size_t k) { return cv.total(k, md); };
  std::size_t best = scores.size();
  for (std::size_t k = 0; k < scores.size(); ++k)
    if (std::isfinite(total(k)) && (best == scores.size() || total(k) < total(best))) best = k;
  if (best == scores.size()) {
    est.message = "noise model: block cross-validation gave no finite score";
    return est;
  }
  std::size_t chosen = one_standard_error(cv, best, md, options);
  chosen = paired_test(cv, chosen, md, options, est);
  est.cv_rms_mm = std::sqrt(total(chosen));
  est.cv_best_rms_mm = std::sqrt(total(best));
  if (!std::isfinite(eps_of[chosen])) {
    est.keep_start = true;
    est.ratio = options.max_ratio;
    est.effective_dof = 0.0;
  } else {
    est.ratio = ratios[chosen];
    double trace = 0;
    for (Eigen::Index i = 0; i < m; ++i) trace += eps_of[chosen] / (lam[i] + eps_of[chosen]);
    est.effective_dof = md - trace;
  }
  est.valid = true;
  est.message = describe(est, m, options);
  return est;
}

}  // namespace brainshift::constraints
