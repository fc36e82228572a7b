#include "tolerance.hpp"

#include "constraints/solver/pgs.hpp"

#include <Eigen/Cholesky>
#include <gtest/gtest.h>

#include <random>

namespace brainshift::constraints {
namespace {

/// Random SPD matrix A = M Mᵀ + n·I (well conditioned, so GS converges in tens of sweeps).
Eigen::MatrixXd random_spd(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  Eigen::MatrixXd M(n, n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) M(i, j) = u(rng);
  return M * M.transpose() + n * Eigen::MatrixXd::Identity(n, n);
}

/// Rows of the given law, each its own group (laws only matter to PGS).
ConstraintRows scalar_rows(int n, ConstraintLaw law) {
  ConstraintRows rows;
  MatrixX3d x = MatrixX3d::Zero(1, 3);
  Stencil s;
  s.add(0, 1.0);
  for (int i = 0; i < n; ++i) {
    if (law == ConstraintLaw::BILATERAL)
      rows.add_sliding_plane(s, x, Vector3d::Zero(), Vector3d::UnitX(), ConstraintSet::LANDMARK);
    else
      rows.add_unilateral_plane(s, x, Vector3d::Zero(), Vector3d::UnitX(),
                                ConstraintSet::FOOTPRINT);
  }
  return rows;
}

TEST(Pgs, BilateralRowsMatchADirectSolve) {
  const int n = 40;
  const Eigen::MatrixXd W = random_spd(n, 1);
  const Eigen::VectorXd delta = Eigen::VectorXd::LinSpaced(n, -3, 5);
  PgsOptions o;
  o.tolerance = 1e-13;
  o.max_iterations = 5000;
  const PgsResult r =
      solve_pgs(W, delta, scalar_rows(n, ConstraintLaw::BILATERAL), Eigen::VectorXd(), o);
  EXPECT_EQ(r.stop, PgsStop::CONVERGED) << r.message;
  const Eigen::VectorXd direct = W.ldlt().solve(-delta);
  // Residual 1e-13 relative and cond(W) ≈ 10 bound the λ error by ≈ 1e-12 relative.
  EXPECT_LT(tests::relative_difference(r.lambda, direct), 1e-10);
}

TEST(Pgs, UnilateralRowsSatisfyTheLcpConditions) {
  const int n = 60;
  const Eigen::MatrixXd W = random_spd(n, 2);
  Eigen::VectorXd delta(n);
  for (int i = 0; i < n; ++i) delta[i] = (i % 3 == 0) ? 2.0 : -1.0 - 0.1 * i;  // mixed signs
  PgsOptions o;
  o.tolerance = 1e-12;
  o.max_iterations = 5000;
  const PgsResult r =
      solve_pgs(W, delta, scalar_rows(n, ConstraintLaw::UNILATERAL), Eigen::VectorXd(), o);
  ASSERT_EQ(r.stop, PgsStop::CONVERGED) << r.message;
  const Eigen::VectorXd g = delta + W * r.lambda;
  const double tol = 1e-9 * delta.cwiseAbs().maxCoeff();  // 1e-12 residual, with margin
  int active = 0;
  for (int i = 0; i < n; ++i) {
    SCOPED_TRACE(i);
    EXPECT_GE(g[i], -tol);
    EXPECT_GE(r.lambda[i], 0.0);
    EXPECT_LE(std::abs(g[i] * r.lambda[i]), tol * std::max(1.0, r.lambda.cwiseAbs().maxCoeff()));
    active += r.lambda[i] > 0;
  }
  EXPECT_GT(active, 0);  // the case is not trivially separated
  EXPECT_LT(active, n);  // nor all in contact
}

TEST(Pgs, ForceBoundIsRespectedAndReported) {
  const int n = 5;
  const Eigen::MatrixXd W = random_spd(n, 3);
  const Eigen::VectorXd delta = Eigen::VectorXd::Constant(n, 100.0);
  PgsOptions o;
  o.lambda_max = 0.5;
  const PgsResult r =
      solve_pgs(W, delta, scalar_rows(n, ConstraintLaw::BILATERAL), Eigen::VectorXd(), o);
  EXPECT_LE(r.lambda.cwiseAbs().maxCoeff(), 0.5);
  EXPECT_GT(r.bounded_rows, 0);
  EXPECT_NE(r.stop, PgsStop::CONVERGED);  // bounded forces cannot close 100 mm gaps
  EXPECT_NE(r.message.find("lambda_max"), std::string::npos) << r.message;
}

TEST(Pgs, WarmStartFromTheSolutionConvergesInOneSweep) {
  const int n = 30;
  const Eigen::MatrixXd W = random_spd(n, 4);
  const Eigen::VectorXd delta = Eigen::VectorXd::LinSpaced(n, -1, 1);
  const auto rows = scalar_rows(n, ConstraintLaw::BILATERAL);
  PgsOptions o;
  o.tolerance = 1e-10;
  const PgsResult cold = solve_pgs(W, delta, rows, Eigen::VectorXd(), o);
  const PgsResult warm = solve_pgs(W, delta, rows, cold.lambda, o);
  EXPECT_GT(cold.iterations, 3);
  EXPECT_EQ(warm.iterations, 1);
}

TEST(Pgs, NoRowsIsAStatusNotAnError) {
  const PgsResult r =
      solve_pgs(Eigen::MatrixXd(0, 0), Eigen::VectorXd(0), ConstraintRows(), Eigen::VectorXd());
  EXPECT_EQ(r.stop, PgsStop::NO_ROWS);
  EXPECT_EQ(r.lambda.size(), 0);
}

}  // namespace
}  // namespace brainshift::constraints
