#include "core/error.hpp"
#include "core/solver/inverse_block.hpp"

#include <Eigen/Cholesky>
#include <gtest/gtest.h>

#include <algorithm>
#include <numeric>
#include <random>
#include <vector>

namespace brainshift::core {
namespace {

/// The 7-point Laplacian of a k×k×k grid plus shift·I: a mesh-like SPD matrix whose Cholesky
/// factor fills in the way a tetrahedral stiffness does (3-D separators).
SparseMatrix grid_laplacian(int k, double shift) {
  const int n = k * k * k;
  auto id = [k](int i, int j, int l) { return (i * k + j) * k + l; };
  std::vector<Triplet> t;
  for (int i = 0; i < k; ++i)
    for (int j = 0; j < k; ++j)
      for (int l = 0; l < k; ++l) {
        const int p = id(i, j, l);
        t.emplace_back(p, p, 6.0 + shift);
        if (i + 1 < k)
          t.emplace_back(p, id(i + 1, j, l), -1.0), t.emplace_back(id(i + 1, j, l), p, -1.0);
        if (j + 1 < k)
          t.emplace_back(p, id(i, j + 1, l), -1.0), t.emplace_back(id(i, j + 1, l), p, -1.0);
        if (l + 1 < k)
          t.emplace_back(p, id(i, j, l + 1), -1.0), t.emplace_back(id(i, j, l + 1), p, -1.0);
      }
  SparseMatrix A(n, n);
  A.setFromTriplets(t.begin(), t.end());
  A.makeCompressed();
  return A;
}

/// `count` distinct indices of [0, n) in a shuffled order.
std::vector<index_t> random_indices(index_t n, index_t count, unsigned seed) {
  std::vector<index_t> all(static_cast<std::size_t>(n));
  std::iota(all.begin(), all.end(), index_t{0});
  std::mt19937 rng(seed);
  std::shuffle(all.begin(), all.end(), rng);
  all.resize(static_cast<std::size_t>(count));
  return all;
}

/// The reference: the dense inverse's block.
Eigen::MatrixXd dense_block(const SparseMatrix& A, const std::vector<index_t>& s) {
  const Eigen::MatrixXd inv =
      Eigen::MatrixXd(A).llt().solve(Eigen::MatrixXd::Identity(A.rows(), A.cols()));
  Eigen::MatrixXd B(s.size(), s.size());
  for (std::size_t j = 0; j < s.size(); ++j)
    for (std::size_t i = 0; i < s.size(); ++i) B(i, j) = inv(s[i], s[j]);
  return B;
}

// Against the dense inverse on a 1,331-unknown grid with 150 shuffled indices (three 64-column
// chunks, the last partial). The matrix's condition number is ≈ 1.2e3 (eigenvalues 0.01+0.2 …
// 12), so both routes agree to ≈ 1e-13 relative; 1e-10 leaves room for the summation order.
TEST(InverseBlock, EqualsTheDenseInversesBlock) {
  const SparseMatrix A = grid_laplacian(11, 0.01);
  const std::vector<index_t> s = random_indices(A.rows(), 150, 7);
  const InverseBlockResult r = inverse_block(A, s);
  ASSERT_TRUE(r.ok) << r.message;
  const Eigen::MatrixXd ref = dense_block(A, s);
  ASSERT_EQ(r.block.rows(), 150);
  EXPECT_LE((r.block - ref).norm(), 1e-10 * ref.norm());
  EXPECT_TRUE(r.block.isApprox(r.block.transpose(), 0.0)) << "exactly symmetric";
}

// Threads share out column chunks; each chunk is computed the same way: bit-identical blocks.
TEST(InverseBlock, ThreadsGiveTheSameBlockBitForBit) {
  const SparseMatrix A = grid_laplacian(9, 0.1);
  const std::vector<index_t> s = random_indices(A.rows(), 200, 3);
  const InverseBlockResult one = inverse_block(A, s, 1);
  const InverseBlockResult three = inverse_block(A, s, 3);
  ASSERT_TRUE(one.ok && three.ok);
  EXPECT_EQ((one.block - three.block).cwiseAbs().maxCoeff(), 0.0);
}

// Edge cases: every index (no interior), one index (the 1×1 block = a diagonal entry of A⁻¹),
// no index (an empty block).
TEST(InverseBlock, AllOneAndNoIndices) {
  const SparseMatrix A = grid_laplacian(5, 0.5);
  std::vector<index_t> all = random_indices(A.rows(), A.rows(), 11);
  const InverseBlockResult r_all = inverse_block(A, all);
  ASSERT_TRUE(r_all.ok);
  const Eigen::MatrixXd ref_all = dense_block(A, all);
  EXPECT_LE((r_all.block - ref_all).norm(), 1e-10 * ref_all.norm());
  const std::vector<index_t> one = {42};
  const InverseBlockResult r_one = inverse_block(A, one);
  ASSERT_TRUE(r_one.ok);
  EXPECT_NEAR(r_one.block(0, 0), dense_block(A, one)(0, 0), 1e-12);
  const InverseBlockResult r_none = inverse_block(A, std::vector<index_t>{});
  EXPECT_TRUE(r_none.ok);
  EXPECT_EQ(r_none.block.size(), 0);
}

// A matrix that is not positive definite is a diagnosis, not an exception or a NaN block; bad
// indices are the caller's error.
TEST(InverseBlock, IndefiniteMatrixAndBadIndices) {
  SparseMatrix A = grid_laplacian(5, 0.5);
  A.coeffRef(60, 60) = -1.0;
  const InverseBlockResult r = inverse_block(A, std::vector<index_t>{1, 2, 3});
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.message.find("not positive definite"), std::string::npos) << r.message;
  EXPECT_EQ(r.block.size(), 0);
  const SparseMatrix B = grid_laplacian(4, 0.5);
  EXPECT_THROW(inverse_block(B, std::vector<index_t>{1, 64}), Error);
  EXPECT_THROW(inverse_block(B, std::vector<index_t>{1, 1}), Error);
  EXPECT_THROW(inverse_block(SparseMatrix(3, 4), std::vector<index_t>{}), Error);
}

}  // namespace
}  // namespace brainshift::core
