// The direct active-set solve on its own (issue 19 item 1): against an independent direct
// solution of the LCP (every active set enumerated, the one meeting the laws kept), with PGS
// confirming it in one sweep — PGS silently repairs a wrong answer, so the sweep count is what
// shows a wrong one — and one test per fallback.
#include "constraints/solver/active_set.hpp"

#include <Eigen/Cholesky>
#include <gtest/gtest.h>

#include <limits>
#include <optional>
#include <random>

namespace brainshift::constraints {
namespace {

/// `nb` bilateral then `nu` unilateral scalar rows, each its own group (only the laws matter here).
ConstraintRows mixed_rows(int nb, int nu) {
  ConstraintRows rows;
  const MatrixX3d x = MatrixX3d::Zero(1, 3);
  Stencil s;
  s.add(0, 1.0);
  for (int i = 0; i < nb; ++i)
    rows.add_sliding_plane(s, x, Vector3d::Zero(), Vector3d::UnitX(), ConstraintSet::LANDMARK);
  for (int i = 0; i < nu; ++i)
    rows.add_unilateral_plane(s, x, Vector3d::Zero(), Vector3d::UnitX(), ConstraintSet::FOOTPRINT);
  return rows;
}

/// The LCP's solution by enumeration: for every subset S of the unilateral rows, solve the rows
/// (bilateral ∪ S) exactly and keep the λ with λ_S ≥ 0 and g ≥ 0 on the other unilateral rows.
/// Unique for a positive definite W.
std::optional<Eigen::VectorXd> enumerated_lcp(const Eigen::MatrixXd& W, const Eigen::VectorXd& d,
                                              int nb) {
  const int m = static_cast<int>(d.size()), nu = m - nb;
  for (int mask = 0; mask < (1 << nu); ++mask) {
    std::vector<int> A;
    for (int i = 0; i < nb; ++i) A.push_back(i);
    for (int j = 0; j < nu; ++j)
      if (mask & (1 << j)) A.push_back(nb + j);
    Eigen::MatrixXd WA(A.size(), A.size());
    Eigen::VectorXd rhs(A.size());
    for (std::size_t a = 0; a < A.size(); ++a) {
      rhs[a] = -d[A[a]];
      for (std::size_t b = 0; b < A.size(); ++b) WA(a, b) = W(A[a], A[b]);
    }
    const Eigen::VectorXd lA = WA.llt().solve(rhs);
    Eigen::VectorXd lambda = Eigen::VectorXd::Zero(m);
    for (std::size_t a = 0; a < A.size(); ++a) lambda[A[a]] = lA[a];
    const Eigen::VectorXd g = d + W * lambda;
    bool ok = true;
    for (int i = nb; i < m; ++i) ok = ok && lambda[i] >= -1e-12 && g[i] >= -1e-12;
    if (ok) return lambda;
  }
  return std::nullopt;
}

TEST(ActiveSet, MatchesTheEnumeratedLcpOnRandomMixedProblemsAndPgsConfirmsInOneSweep) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1, 1);
  int with_contacts_active = 0;
  for (int trial = 0; trial < 40; ++trial) {
    const int nb = 1 + trial % 4, nu = 3 + trial % 5, m = nb + nu;
    Eigen::MatrixXd M(m, m);
    for (int i = 0; i < m; ++i)
      for (int j = 0; j < m; ++j) M(i, j) = u(rng);
    // Positive definite but strongly coupled (off-diagonal terms of the order of the diagonal),
    // as neighbouring contact rows on one element are.
    const Eigen::MatrixXd W = M * M.transpose() + 0.2 * Eigen::MatrixXd::Identity(m, m);
    Eigen::VectorXd d(m);
    for (int i = 0; i < m; ++i) d[i] = u(rng);
    const ConstraintRows rows = mixed_rows(nb, nu);
    const auto truth = enumerated_lcp(W, d, nb);
    ASSERT_TRUE(truth.has_value()) << "trial " << trial;
    PgsOptions o;
    o.tolerance = 1e-8;
    const PgsResult r =
        solve_constraints(W, d, rows, Eigen::VectorXd(), o, ConstraintSolver::ACTIVE_SET);
    SCOPED_TRACE("trial " + std::to_string(trial));
    EXPECT_EQ(r.active_set, ActiveSetOutcome::SOLVED);
    // Same λ as the independent solution, to the 1e-12 regularisation of the active block
    // amplified by W's conditioning (≤ 1e4 here): 1e-7 relative.
    EXPECT_LT((r.lambda - *truth).norm(), 1e-7 * std::max(1.0, truth->norm()));
    // PGS verifies an exact answer in its first sweep; a wrong one (half the forces, a wrong
    // set) takes it tens to hundreds of sweeps to repair.
    EXPECT_EQ(r.iterations, 1);
    EXPECT_EQ(r.stop, PgsStop::CONVERGED);
    for (int i = nb; i < m; ++i) with_contacts_active += (*truth)[i] > 1e-9;
  }
  EXPECT_GT(with_contacts_active, 20);  // the trials do exercise active unilateral rows
}

TEST(ActiveSet, FallbackWhenTheActiveBlockCannotBeFactorised) {
  // An indefinite block whose LDLᵀ meets an exact zero pivot with a non-zero column below it
  // (after the solver's 1e-12 diagonal regularisation, all three diagonals equal b): not a valid
  // Delassus operator, but the solver must hand over to PGS rather than use a broken factor.
  const double b = 1.0 + 1e-12 * 1.0;
  Eigen::MatrixXd W(3, 3);
  W << 1.0, b, b, b, 1.0, b + 0.5, b, b + 0.5, 1.0;
  const Eigen::VectorXd d = Eigen::Vector3d(-1.0, 0.5, 0.2);
  PgsOptions o;
  o.max_iterations = 20;
  PgsResult r;
  EXPECT_NO_THROW(r = solve_constraints(W, d, mixed_rows(3, 0), Eigen::VectorXd(), o,
                                        ConstraintSolver::ACTIVE_SET));
  EXPECT_EQ(r.active_set, ActiveSetOutcome::LDLT_FAILED);
}

TEST(ActiveSet, FallbackWhenTheSolveIsNotFinite) {
  // W ≈ 1e-300 and δ ≈ 1e300: λ = −δ / W overflows.
  const Eigen::MatrixXd W = 1e-300 * Eigen::MatrixXd::Identity(2, 2);
  const Eigen::VectorXd d = Eigen::Vector2d(1e300, -1e300);
  PgsOptions o;
  o.max_iterations = 5;
  PgsResult r;
  EXPECT_NO_THROW(r = solve_constraints(W, d, mixed_rows(2, 0), Eigen::VectorXd(), o,
                                        ConstraintSolver::ACTIVE_SET));
  EXPECT_EQ(r.active_set, ActiveSetOutcome::NON_FINITE);
}

/// A chain of unilateral contacts (W = I − 0.45·path adjacency, positive definite): pushing the
/// first row makes the second violated, which then makes the third violated: the set needs two
/// changes to settle.
struct Chain {
  Eigen::MatrixXd W = Eigen::MatrixXd::Identity(4, 4);
  Eigen::VectorXd d = Eigen::Vector4d(-1.0, 0.1, 0.1, 0.1);
  Chain() {
    for (int i = 0; i + 1 < 4; ++i) W(i, i + 1) = W(i + 1, i) = -0.45;
  }
};

TEST(ActiveSet, FallbackWhenTheSetDoesNotSettleWithinTheAllowedChanges) {
  const Chain c;
  PgsOptions o;
  const PgsResult full = solve_constraints(c.W, c.d, mixed_rows(0, 4), Eigen::VectorXd(), o,
                                           ConstraintSolver::ACTIVE_SET);
  ASSERT_EQ(full.active_set, ActiveSetOutcome::SOLVED);
  EXPECT_GE(full.active_set_changes, 2);  // the chain does need two changes
  o.active_set_max_changes = 1;
  const PgsResult capped = solve_constraints(c.W, c.d, mixed_rows(0, 4), Eigen::VectorXd(), o,
                                             ConstraintSolver::ACTIVE_SET);
  EXPECT_EQ(capped.active_set, ActiveSetOutcome::NO_SETTLING);
  // PGS finishes it from the warm start (zero): the same answer, with more sweeps.
  EXPECT_EQ(capped.stop, PgsStop::CONVERGED);
  EXPECT_LT((capped.lambda - full.lambda).norm(),
            1e-4 * full.lambda.norm());  // PGS tolerance 1e-6 relative, conditioned by W
  EXPECT_GT(capped.iterations, 1);
}

TEST(ActiveSet, FallbackWhenTheActiveRowsContradictEachOther) {
  // Two bilateral rows on the same direction of the same point with opposite targets: no λ
  // meets both; the regularised solve leaves a residual and PGS must diagnose it.
  Eigen::MatrixXd W(2, 2);
  W << 1.0, 1.0, 1.0, 1.0;
  const Eigen::VectorXd d = Eigen::Vector2d(-1.0, 1.0);
  PgsOptions o;
  o.max_iterations = 300;
  const PgsResult r =
      solve_constraints(W, d, mixed_rows(2, 0), Eigen::VectorXd(), o, ConstraintSolver::ACTIVE_SET);
  EXPECT_EQ(r.active_set, ActiveSetOutcome::INCONSISTENT);
  EXPECT_NE(r.stop, PgsStop::CONVERGED);
  EXPECT_TRUE(r.lambda.allFinite());
}

}  // namespace
}  // namespace brainshift::constraints
