// The noise model's GCV choice on a problem whose answer is known: a smooth Gaussian-process
// prior over 120 points on a line (W = the kernel matrix), observations = a smooth signal plus
// white noise of known σ. GCV must read σ back and smooth more when there is more noise; pure
// noise must leave the model where it is (the largest compliance), which is what "never worse
// than rigid" asks of the registration.
#include "constraints/registration/noise/noise_model.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

namespace brainshift::constraints {
namespace {

struct Problem {
  Eigen::MatrixXd W;
  Eigen::VectorXd signal;
  std::vector<index_t> rows;
  explicit Problem(int m = 120, double length = 0.08) : W(m, m), signal(m) {
    for (int i = 0; i < m; ++i) {
      const double ti = static_cast<double>(i) / (m - 1);
      signal[i] = std::sin(2 * std::numbers::pi * ti) + 0.5 * std::cos(5 * ti);
      rows.push_back(i);
      for (int j = 0; j < m; ++j) {
        const double tj = static_cast<double>(j) / (m - 1);
        W(i, j) = std::exp(-0.5 * (ti - tj) * (ti - tj) / (length * length));
      }
    }
  }
  Eigen::VectorXd observed(double sigma, unsigned seed, double signal_scale = 1.0) const {
    std::mt19937 rng(seed);
    std::normal_distribution<double> n(0.0, sigma);
    Eigen::VectorXd y = signal_scale * signal;
    for (Eigen::Index i = 0; i < y.size(); ++i) y[i] += n(rng);
    return y;
  }
};

NoiseOptions wide() {
  NoiseOptions o;
  o.min_ratio = 1e-4;
  o.max_ratio = 1e3;
  o.grid = 90;
  return o;
}

TEST(NoiseModel, ReadsBackTheNoiseLevelAndSmoothsMoreWhenThereIsMoreNoise) {
  const Problem p;
  double previous_ratio = 0;
  for (double sigma : {0.05, 0.2, 0.5}) {
    const NoiseEstimate e =
        estimate_vessel_noise(p.W, p.observed(sigma, 3), p.rows, 1.0, 0.2, wide());
    ASSERT_TRUE(e.valid) << e.message;
    // GCV's σ̂ from 120 samples: within 30 % of the truth (its sampling spread is ≈ 10 %).
    EXPECT_NEAR(e.sigma_mm, sigma, 0.3 * sigma) << e.message;
    EXPECT_GT(e.ratio, previous_ratio) << e.message;  // more noise, more compliance
    EXPECT_LT(e.effective_dof, 60.0);                 // a smooth fit, not an interpolation
    previous_ratio = e.ratio;
  }
}

TEST(NoiseModel, PureNoiseLeavesTheModelWhereItIs) {
  const Problem p;
  const NoiseEstimate e =
      estimate_vessel_noise(p.W, p.observed(0.5, 4, 0.0), p.rows, 1.0, 0.2, wide());
  ASSERT_TRUE(e.valid) << e.message;
  // Nothing to explain: the chosen compliance is high and the fit follows fewer than 5 of the
  // 120 degrees of freedom (an interpolation follows all of them).
  EXPECT_GE(e.ratio, 10.0) << e.message;
  EXPECT_LT(e.effective_dof, 5.0) << e.message;
}

TEST(NoiseModel, TooFewRowsKeepTheCurrentCompliance) {
  const Problem p(6);
  const NoiseEstimate e = estimate_vessel_noise(p.W, p.observed(0.1, 5), p.rows, 1.0, 0.2, wide());
  EXPECT_FALSE(e.valid);
  EXPECT_EQ(e.ratio, 0.2);
}

}  // namespace
}  // namespace brainshift::constraints
