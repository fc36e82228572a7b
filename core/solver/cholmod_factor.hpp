#pragma once
/// @file
/// @brief CHOLMOD supernodal Cholesky factor A = P L Lᵀ Pᵀ with the analyse / factorise /
/// solve split (symbolic once per sparsity pattern, numeric per matrix, solve per right-hand side).

#include "core/config.hpp"

#include <memory>
#include <string>
#include <vector>

namespace brainshift::core {

/// Outcome of a numeric factorisation (a status, not an exception: STYLE §28).
enum class FactorStatus {
  OK,
  NOT_POSITIVE_DEFINITE,  ///< CHOLMOD hit a non-positive pivot (singular or indefinite matrix)
  FAILED,                 ///< any other CHOLMOD failure (out of memory, ...)
};

/// Owns a CHOLMOD common and factor. Move-only. Not thread-safe for concurrent solves
/// (CHOLMOD's common workspace is shared); const methods do not modify observable state.
class CholmodFactor {
 public:
  CholmodFactor();
  ~CholmodFactor();
  CholmodFactor(CholmodFactor&&) noexcept;
  CholmodFactor& operator=(CholmodFactor&&) noexcept;
  CholmodFactor(const CholmodFactor&) = delete;
  CholmodFactor& operator=(const CholmodFactor&) = delete;

  /// Symbolic analysis (fill-reducing ordering, supernodes) of the pattern of the symmetric A.
  /// Only the lower triangle of A is read. \throws brainshift::Error if A is not square.
  void analyze(const SparseMatrix& A);
  /// Numeric LLᵀ factorisation of A (same pattern as analyze()). Returns the status; on
  /// NOT_POSITIVE_DEFINITE, message() names the failing column.
  FactorStatus factorize(const SparseMatrix& A);
  /// analyze() then factorize().
  FactorStatus compute(const SparseMatrix& A);

  [[nodiscard]] bool ok() const { return m_status == FactorStatus::OK; }
  [[nodiscard]] FactorStatus status() const { return m_status; }
  [[nodiscard]] const std::string& message() const { return m_message; }
  [[nodiscard]] index_t rows() const { return m_rows; }
  /// Non-zeros of L (memory indicator).
  [[nodiscard]] std::size_t factor_nonzeros() const;

  /// x = A⁻¹ b. \pre ok(). \throws brainshift::Error otherwise or on a size mismatch.
  [[nodiscard]] Eigen::VectorXd solve(ConstRef<Eigen::VectorXd> b) const;
  /// X = A⁻¹ B for several dense right-hand sides (columns).
  [[nodiscard]] Eigen::MatrixXd solve(ConstRef<Eigen::MatrixXd> B) const;
  /// Exact-type overloads of the two solves above. They exist because a plain VectorXd (or
  /// MatrixXd) converts equally well to both Ref parameters, which makes `solve(b)` ambiguous;
  /// these win overload resolution. Expressions must be evaluated first (`solve(VectorXd(e))`).
  [[nodiscard]] Eigen::VectorXd solve(const Eigen::VectorXd& b) const;
  [[nodiscard]] Eigen::MatrixXd solve(const Eigen::MatrixXd& B) const;
  /// X = A⁻¹ B like solve(), but with a CHOLMOD workspace of its own (created and freed per
  /// call), so several threads may call it at once on one factor (CHOLMOD's solve reads the
  /// factor only); no other method may run meanwhile. Same result as solve(), bit for bit.
  [[nodiscard]] Eigen::MatrixXd solve_concurrent(ConstRef<Eigen::MatrixXd> B) const;
  /// Y = L⁻¹ P B for a sparse B (rows(A)×k), sparse result: then Bᵀ A⁻¹ B = Yᵀ Y.
  [[nodiscard]] SparseMatrix solve_lower_permuted(const SparseMatrix& B) const;

 private:
  friend class SingleFactor;
  struct Impl;
  std::unique_ptr<Impl> m_impl;
  FactorStatus m_status = FactorStatus::FAILED;
  std::string m_message = "not factorised";
  index_t m_rows = 0;
};

/// A single-precision copy of a supernodal CholmodFactor's L, for solves whose factor is
/// larger than the caches: such a solve is bound by reading L (twice, forward and back), and
/// float halves that traffic (the 19.7k-node box, nnz(L) = 46 M: 37 → 22 ms; bench_core
/// `BM_CholmodSolve*`, docs/BENCHMARKS.md). The solve is exact for a matrix within float
/// round-off of A, so its relative error is about cond(A) · 6e-8 (1.5e-6 on that box;
/// tests/core/solver/test_cholmod_factor.cpp, `SingleFactor.*`). Used where the solve is one step
/// of a fixed-point iteration that recomputes its residual in double (the registration's free
/// motion and correction), so the error moves the path, never the fixed point.
class SingleFactor {
 public:
  /// Copies L's values (rounded to the nearest float). \pre factor.ok(), and factor is not
  /// analysed or factorised again while this copy is used (it reads factor's structure).
  /// \throws brainshift::Error when the factor is not usable or not supernodal LLᵀ.
  explicit SingleFactor(const CholmodFactor& factor);
  /// x ≈ A⁻¹ b: b rounded to float, L y = P b and Lᵀ z = y by BLAS strsv / sgemv over the
  /// supernodes, x = Pᵀ z widened to double.
  [[nodiscard]] Eigen::VectorXd solve(ConstRef<Eigen::VectorXd> b) const;
  [[nodiscard]] index_t rows() const { return m_rows; }
  /// Bytes of the copy.
  [[nodiscard]] std::size_t bytes() const { return m_values.size() * sizeof(float); }

 private:
  const CholmodFactor* m_factor;  // not owned
  std::vector<float> m_values;
  index_t m_rows = 0;
};

}  // namespace brainshift::core
