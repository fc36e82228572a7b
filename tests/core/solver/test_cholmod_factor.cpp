#include "tolerance.hpp"

#include "core/error.hpp"
#include "core/solver/cholmod_factor.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <gtest/gtest.h>

#include <iostream>
#include <random>
#include <string>
#include <utility>

namespace brainshift::core {
namespace {

/// Random sparse SPD matrix: A = M Mᵀ + shift·I with M sparse (≈ `per_col` entries a column).
SparseMatrix random_spd(int n, int per_col, double shift, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> row(0, n - 1);
  std::normal_distribution<double> normal;
  std::vector<Triplet> t;
  for (int j = 0; j < n; ++j) {
    t.emplace_back(j, j, 1.0);
    for (int k = 0; k < per_col; ++k) t.emplace_back(row(rng), j, normal(rng));
  }
  SparseMatrix M(n, n);
  M.setFromTriplets(t.begin(), t.end());
  SparseMatrix I(n, n);
  I.setIdentity();
  SparseMatrix A = M * SparseMatrix(M.transpose()) + shift * I;
  A.makeCompressed();
  return A;
}

Eigen::MatrixXd random_dense(Eigen::Index rows, Eigen::Index cols, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> normal;
  Eigen::MatrixXd B(rows, cols);
  for (Eigen::Index i = 0; i < B.size(); ++i) B.data()[i] = normal(rng);
  return B;
}

double condition_number(const SparseMatrix& A) {
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig{Eigen::MatrixXd(A)};
  return eig.eigenvalues().maxCoeff() / eig.eigenvalues().minCoeff();
}

TEST(CholmodFactor, SolveAgreesWithDenseLlt) {
  const SparseMatrix A = random_spd(300, 3, 1e-2, 42);
  const double cond = condition_number(A);
  CholmodFactor factor;
  ASSERT_EQ(factor.compute(A), FactorStatus::OK) << factor.message();
  EXPECT_TRUE(factor.ok());
  EXPECT_EQ(factor.rows(), 300);
  EXPECT_GT(factor.factor_nonzeros(), 0u);
  const Eigen::LLT<Eigen::MatrixXd> llt{Eigen::MatrixXd(A)};
  const Eigen::MatrixXd B = random_dense(300, 4, 7);
  const Eigen::MatrixXd X = factor.solve(B);
  const Eigen::MatrixXd X_dense = llt.solve(B);
  // Each Cholesky solve is backward stable: forward error ≤ c·n·ε·cond with modest c; two
  // of them differ by at most the sum. 1e3·ε·cond covers c·n for n = 300 in practice (the
  // worst-case bound is pessimistic by orders of magnitude for random matrices).
  const double tol = 1e3 * tests::eps * cond;
  const double diff = tests::relative_difference(X, X_dense);
  EXPECT_LE(diff, tol) << "cond " << cond;
  std::cout << "[ measured ] CHOLMOD vs LLT relative difference " << diff << " (cond " << cond
            << ", tolerance " << tol << ")\n";
  const Eigen::VectorXd b = B.col(2);
  EXPECT_LE(tests::relative_difference(factor.solve(b), X_dense.col(2)), tol);
  // Residual check independent of the dense reference: backward error ~ n·ε.
  EXPECT_LE((A * X - B).norm(), 1e-10 * A.norm() * X.norm());
}

TEST(CholmodFactor, LowerPermutedSolveGivesTheCongruence) {
  const SparseMatrix A = random_spd(200, 3, 0.5, 9);
  CholmodFactor factor;
  ASSERT_EQ(factor.compute(A), FactorStatus::OK) << factor.message();
  // Sparse right-hand sides with a few entries a column (like Hᵀ rows).
  std::vector<Triplet> t = {{3, 0, 1.0}, {150, 0, -0.5}, {77, 1, 2.0}, {3, 2, 0.3}, {199, 2, 1.0}};
  SparseMatrix B(200, 3);
  B.setFromTriplets(t.begin(), t.end());
  const SparseMatrix Y = factor.solve_lower_permuted(B);
  ASSERT_EQ(Y.rows(), 200);
  ASSERT_EQ(Y.cols(), 3);
  const Eigen::MatrixXd W = Eigen::MatrixXd(SparseMatrix(Y.transpose()) * Y);
  const Eigen::MatrixXd W_ref = Eigen::MatrixXd(B.transpose()) * factor.solve(Eigen::MatrixXd(B));
  // Two factorisation-based evaluations of Bᵀ A⁻¹ B (cond(A) ~ 1e2): 1e-10 relative.
  EXPECT_LE(tests::relative_difference(W, W_ref), 1e-10);
}

TEST(CholmodFactor, IndefiniteMatrixReportsNotPositiveDefiniteWithoutThrowing) {
  SparseMatrix A = random_spd(50, 2, 1.0, 3);
  A.coeffRef(20, 20) = -1e3;  // a negative diagonal entry makes A indefinite
  CholmodFactor factor;
  FactorStatus status = FactorStatus::OK;
  EXPECT_NO_THROW(status = factor.compute(A));
  EXPECT_EQ(status, FactorStatus::NOT_POSITIVE_DEFINITE);
  EXPECT_FALSE(factor.ok());
  EXPECT_NE(factor.message().find("column"), std::string::npos) << factor.message();
  EXPECT_THROW((void)factor.solve(Eigen::VectorXd(Eigen::VectorXd::Ones(50))), Error);

  SparseMatrix singular(3, 3);  // a zero column: positive semi-definite only
  singular.insert(0, 0) = 1.0;
  singular.insert(2, 2) = 1.0;
  EXPECT_EQ(factor.compute(singular), FactorStatus::NOT_POSITIVE_DEFINITE);
  EXPECT_NE(factor.message().find("column 1"), std::string::npos) << factor.message();
}

TEST(CholmodFactor, RefactorisingAndMovingKeepTheFactorUsable) {
  const SparseMatrix A = random_spd(80, 2, 1.0, 5);
  CholmodFactor factor;
  factor.analyze(A);
  ASSERT_EQ(factor.factorize(A), FactorStatus::OK);
  const SparseMatrix A2 = 2.0 * A;  // same pattern, new values: numeric factorisation only
  ASSERT_EQ(factor.factorize(A2), FactorStatus::OK);
  const Eigen::VectorXd b = random_dense(80, 1, 1).col(0);
  const Eigen::VectorXd x = factor.solve(b);
  CholmodFactor moved(std::move(factor));
  EXPECT_FALSE(factor.ok());  // NOLINT(bugprone-use-after-move): moved-from state is defined
  // Same factor, same solve: bitwise equal.
  EXPECT_EQ(moved.solve(b), x);
  CholmodFactor assigned;
  assigned = std::move(moved);
  EXPECT_EQ(assigned.solve(b), x);
  // Solution of 2A x = b (cond ~1e1–1e2): residual at rounding level.
  EXPECT_LE((A2 * x - b).norm(), 1e-12 * b.norm() * 1e2);
  EXPECT_THROW(assigned.analyze(SparseMatrix(3, 4)), Error);
  EXPECT_THROW((void)assigned.solve(Eigen::VectorXd(Eigen::VectorXd::Ones(7))), Error);
}

/// Float's unit round-off (2⁻²⁴): L and the triangular solves of SingleFactor are in float.
constexpr double kFloatRoundOff = 0x1p-24;

TEST(SingleFactor, SolvesWithTheBackwardErrorOfFloatAndAForwardErrorBoundedByTheCondition) {
  // 600 rows, ≈ 7 entries a row: CHOLMOD makes supernodes with rows below their diagonal
  // blocks and a fill-reducing permutation, every path of the float solve.
  const SparseMatrix A = random_spd(600, 3, 0.5, 11);
  const double cond = condition_number(A);
  CholmodFactor factor;
  ASSERT_EQ(factor.compute(A), FactorStatus::OK) << factor.message();
  const SingleFactor single(factor);
  EXPECT_EQ(single.rows(), 600);
  EXPECT_EQ(single.bytes(), factor.factor_nonzeros() * sizeof(float));
  const Eigen::MatrixXd B = random_dense(600, 3, 13);
  const Eigen::MatrixXd X_dense = Eigen::LLT<Eigen::MatrixXd>{Eigen::MatrixXd(A)}.solve(B);
  for (Eigen::Index j = 0; j < B.cols(); ++j) {
    const Eigen::VectorXd b = B.col(j);
    const Eigen::VectorXd x = single.solve(b);
    // Backward error, independent of the condition: x solves (A + E) x = b with ‖E‖ a few
    // float round-offs of ‖A‖ times the entries a row of L (L rounded, then two triangular
    // solves in float); 100 u ‖A‖ ‖x‖ covers it with the rows of this matrix (≤ 60 in L).
    EXPECT_LE((A * x - b).norm(), 100 * kFloatRoundOff * A.norm() * x.norm());
    // Forward error ≤ cond · (backward error); the same 100 u.
    const double diff = tests::relative_difference(x, X_dense.col(j));
    EXPECT_LE(diff, 100 * kFloatRoundOff * cond) << "cond " << cond;
    // And it is float's, not double's: far above what CHOLMOD's double solve leaves (≈ 1e-15
    // · cond), so a solve that silently ran in double would show here.
    EXPECT_GT(diff, 1e3 * tests::eps * cond);
    std::cout << "[ measured ] single-precision solve: relative error " << diff << ", cond " << cond
              << "\n";
  }
}

TEST(SingleFactor, RefusesAFactorThatIsNotUsableAndAWrongSize) {
  const SparseMatrix A = random_spd(40, 2, 1.0, 3);
  CholmodFactor factor;
  EXPECT_THROW(SingleFactor{factor}, Error);  // not factorised
  ASSERT_EQ(factor.compute(A), FactorStatus::OK);
  const SingleFactor single(factor);
  EXPECT_THROW((void)single.solve(Eigen::VectorXd(Eigen::VectorXd::Ones(7))), Error);
  EXPECT_TRUE(single.solve(Eigen::VectorXd(Eigen::VectorXd::Ones(40))).allFinite());
}

}  // namespace
}  // namespace brainshift::core
