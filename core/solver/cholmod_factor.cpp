#include "core/solver/cholmod_factor.hpp"

#include "core/error.hpp"
#include "core/solver/cholmod_views.hpp"

#include <cholmod.h>

#include <algorithm>
#include <sstream>
#include <utility>
#include <vector>

extern "C" {
// Fortran BLAS (served by the process's BLAS: OpenBLAS, see cmake/deps/blas.cmake).
void strsv_(const char* uplo, const char* trans, const char* diag, const int* n, const float* a,
            const int* lda, float* x, const int* incx);
void sgemv_(const char* trans, const int* m, const int* n, const float* alpha, const float* a,
            const int* lda, const float* x, const int* incx, const float* beta, float* y,
            const int* incy);
}

namespace brainshift::core {

/// The CHOLMOD workspace and factor. The common is modified by every CHOLMOD call, including
/// solves, hence the class-level note that concurrent solves are not thread-safe.
struct CholmodFactor::Impl {
  cholmod_common common{};
  cholmod_factor* factor = nullptr;
  index_t analyzed_rows = -1;

  Impl() {
    cholmod_start(&common);
    common.supernodal = CHOLMOD_SUPERNODAL;  // supernodal LLᵀ (BLAS-3), ARCHITECTURE "K0"
    common.final_ll = 1;                     // keep LLᵀ, so CHOLMOD_L solves with L itself
    common.print = 0;                        // statuses are reported, never printed
    common.error_handler = nullptr;
  }
  ~Impl() {
    if (factor != nullptr) cholmod_free_factor(&factor, &common);
    cholmod_finish(&common);
  }
  Impl(const Impl&) = delete;
  Impl& operator=(const Impl&) = delete;
};

namespace {

using detail::lower_triangle;
using detail::sparse_view;

/// A cholmod_dense view (no copy) of a column-major matrix. `M` must outlive the view.
cholmod_dense dense_view(Eigen::MatrixXd& M) {
  cholmod_dense v{};
  v.nrow = static_cast<std::size_t>(M.rows());
  v.ncol = static_cast<std::size_t>(M.cols());
  v.nzmax = static_cast<std::size_t>(M.size());
  v.d = static_cast<std::size_t>(M.rows());
  v.x = M.data();
  v.z = nullptr;
  v.xtype = CHOLMOD_REAL;
  v.dtype = CHOLMOD_DOUBLE;
  return v;
}

}  // namespace

CholmodFactor::CholmodFactor() : m_impl(std::make_unique<Impl>()) {}
CholmodFactor::~CholmodFactor() = default;

CholmodFactor::CholmodFactor(CholmodFactor&& other) noexcept
    : m_impl(std::move(other.m_impl)),
      m_status(other.m_status),
      m_message(std::move(other.m_message)),
      m_rows(other.m_rows) {
  other.m_status = FactorStatus::FAILED;
  other.m_message = "moved from";
  other.m_rows = 0;
}

CholmodFactor& CholmodFactor::operator=(CholmodFactor&& other) noexcept {
  if (this != &other) {
    m_impl = std::move(other.m_impl);
    m_status = other.m_status;
    m_message = std::move(other.m_message);
    m_rows = other.m_rows;
    other.m_status = FactorStatus::FAILED;
    other.m_message = "moved from";
    other.m_rows = 0;
  }
  return *this;
}

void CholmodFactor::analyze(const SparseMatrix& A) {
  BS_VERIFY(A.rows() == A.cols(),
            "matrix to factorise is not square: " << A.rows() << "×" << A.cols());
  if (!m_impl) m_impl = std::make_unique<Impl>();  // a moved-from factor is usable again
  Impl& impl = *m_impl;
  if (impl.factor != nullptr) cholmod_free_factor(&impl.factor, &impl.common);
  m_status = FactorStatus::FAILED;
  m_message = "analysed, not factorised";
  m_rows = static_cast<index_t>(A.rows());
  SparseMatrix lower = lower_triangle(A);
  cholmod_sparse view = sparse_view(lower, /*stype=*/-1);
  impl.factor = cholmod_analyze(&view, &impl.common);
  impl.analyzed_rows = m_rows;
  if (impl.factor == nullptr || impl.common.status < CHOLMOD_OK) {
    std::ostringstream msg;
    msg << "CHOLMOD symbolic analysis failed (status " << impl.common.status << ") for a " << m_rows
        << "×" << m_rows << " matrix";
    m_message = msg.str();
  }
}

FactorStatus CholmodFactor::factorize(const SparseMatrix& A) {
  BS_VERIFY(m_impl && m_impl->factor != nullptr, "call analyze() before factorize()");
  Impl& impl = *m_impl;
  BS_VERIFY(A.rows() == impl.analyzed_rows && A.cols() == impl.analyzed_rows,
            "matrix is " << A.rows() << "×" << A.cols() << " but analyze() saw "
                         << impl.analyzed_rows << "×" << impl.analyzed_rows);
  SparseMatrix lower = lower_triangle(A);
  cholmod_sparse view = sparse_view(lower, /*stype=*/-1);
  const int ok = cholmod_factorize(&view, impl.factor, &impl.common);
  const auto n = static_cast<std::size_t>(A.rows());
  std::ostringstream msg;
  if (impl.common.status == CHOLMOD_NOT_POSDEF || (ok && impl.factor->minor < n)) {
    const std::size_t minor = impl.factor->minor;
    const auto* perm = static_cast<const int*>(impl.factor->Perm);
    const long column = (perm != nullptr && minor < n) ? perm[minor] : static_cast<long>(minor);
    msg << "matrix is not positive definite: non-positive pivot at column " << column << " (step "
        << minor << " of " << n << "); a singular (under-constrained) or indefinite matrix";
    m_status = FactorStatus::NOT_POSITIVE_DEFINITE;
  } else if (!ok || impl.common.status < CHOLMOD_OK) {
    msg << "CHOLMOD numeric factorisation failed (status " << impl.common.status << ")";
    m_status = FactorStatus::FAILED;
  } else {
    msg << "ok";
    m_status = FactorStatus::OK;
  }
  m_message = msg.str();
  return m_status;
}

FactorStatus CholmodFactor::compute(const SparseMatrix& A) {
  analyze(A);
  if (m_impl->factor == nullptr) return m_status;
  return factorize(A);
}

std::size_t CholmodFactor::factor_nonzeros() const {
  if (!m_impl || m_impl->factor == nullptr) return 0;
  const cholmod_factor& L = *m_impl->factor;
  if (L.is_super) return L.xsize;
  std::size_t nnz = 0;
  const auto* col_counts = static_cast<const int*>(L.nz);
  if (col_counts == nullptr) return 0;
  for (std::size_t j = 0; j < L.n; ++j) nnz += static_cast<std::size_t>(col_counts[j]);
  return nnz;
}

Eigen::VectorXd CholmodFactor::solve(ConstRef<Eigen::VectorXd> b) const {
  const Eigen::MatrixXd B = b;
  return solve(B).col(0);
}

Eigen::VectorXd CholmodFactor::solve(const Eigen::VectorXd& b) const {
  return solve(ConstRef<Eigen::VectorXd>(b));
}

Eigen::MatrixXd CholmodFactor::solve(const Eigen::MatrixXd& B) const {
  return solve(ConstRef<Eigen::MatrixXd>(B));
}

Eigen::MatrixXd CholmodFactor::solve(ConstRef<Eigen::MatrixXd> B) const {
  BS_VERIFY(ok(), "solve() on a factor that is not usable: " << m_message);
  BS_VERIFY(B.rows() == m_rows,
            "right-hand side has " << B.rows() << " rows, the factor " << m_rows);
  Impl& impl = *m_impl;
  Eigen::MatrixXd rhs = B;
  cholmod_dense view = dense_view(rhs);
  cholmod_dense* X = cholmod_solve(CHOLMOD_A, impl.factor, &view, &impl.common);
  BS_VERIFY(X != nullptr, "CHOLMOD solve failed (status " << impl.common.status << ")");
  Eigen::MatrixXd out =
      Eigen::Map<const Eigen::MatrixXd>(static_cast<const double*>(X->x), B.rows(), B.cols());
  cholmod_free_dense(&X, &impl.common);
  return out;
}

Eigen::MatrixXd CholmodFactor::solve_concurrent(ConstRef<Eigen::MatrixXd> B) const {
  BS_VERIFY(ok(), "solve_concurrent() on a factor that is not usable: " << m_message);
  BS_VERIFY(B.rows() == m_rows,
            "right-hand side has " << B.rows() << " rows, the factor " << m_rows);
  cholmod_common common{};
  cholmod_start(&common);
  common.print = 0;
  common.error_handler = nullptr;
  Eigen::MatrixXd rhs = B;
  cholmod_dense view = dense_view(rhs);
  cholmod_dense* X = cholmod_solve(CHOLMOD_A, m_impl->factor, &view, &common);
  if (X == nullptr) {
    const int status = common.status;
    cholmod_finish(&common);
    BS_VERIFY(false, "CHOLMOD solve failed (status " << status << ")");
  }
  Eigen::MatrixXd out =
      Eigen::Map<const Eigen::MatrixXd>(static_cast<const double*>(X->x), B.rows(), B.cols());
  cholmod_free_dense(&X, &common);
  cholmod_finish(&common);
  return out;
}

namespace {

/// x = Pᵀ L⁻ᵀ L⁻¹ P b over CHOLMOD's supernodal L, its values `Lx` in float. Supernode s holds
/// columns super[s] … super[s+1]−1, its rows Ls[pi[s] … pi[s+1]) (the diagonal block's first),
/// its values column-major from Lx[px[s]] with leading dimension nsrow (CHOLMOD's layout).
Eigen::VectorXd supernodal_solve(const cholmod_factor& L, const float* Lx,
                                 ConstRef<Eigen::VectorXd> b) {
  const auto* perm = static_cast<const int*>(L.Perm);
  const auto* super = static_cast<const int*>(L.super);
  const auto* pi = static_cast<const int*>(L.pi);
  const auto* px = static_cast<const int*>(L.px);
  const auto* Ls = static_cast<const int*>(L.s);
  const auto n = static_cast<int>(L.n);
  const auto nsuper = static_cast<int>(L.nsuper);
  std::vector<float> y(static_cast<std::size_t>(n));
  for (int k = 0; k < n; ++k) y[k] = static_cast<float>(b[perm[k]]);  // y = P b
  std::vector<float> t(std::max<std::size_t>(L.maxesize, 1));         // a supernode's rows below
  const int one = 1;
  const float plus = 1.0F, zero = 0.0F, minus = -1.0F;
  // Supernode s: its first column k1, its nscol columns, nsrow rows of which `below` under the
  // diagonal block (their indices `rows`), its values A.
  struct Block {
    int k1, nscol, nsrow, below;
    const float* A;
    const int* rows;
  };
  const auto block = [&](int s) {
    const int nscol = super[s + 1] - super[s], nsrow = pi[s + 1] - pi[s];
    return Block{super[s], nscol, nsrow, nsrow - nscol, Lx + px[s], Ls + pi[s] + nscol};
  };
  // L y = P b: each diagonal block, then the rows below it updated.
  for (int s = 0; s < nsuper; ++s) {
    const auto [k1, nscol, nsrow, below, A, rows] = block(s);
    strsv_("L", "N", "N", &nscol, A, &nsrow, &y[k1], &one);
    if (below == 0) continue;
    sgemv_("N", &below, &nscol, &plus, A + nscol, &nsrow, &y[k1], &one, &zero, t.data(), &one);
    for (int i = 0; i < below; ++i) y[rows[i]] -= t[i];
  }
  // Lᵀ z = y, the supernodes in reverse order.
  for (int s = nsuper - 1; s >= 0; --s) {
    const auto [k1, nscol, nsrow, below, A, rows] = block(s);
    if (below > 0) {
      for (int i = 0; i < below; ++i) t[i] = y[rows[i]];
      sgemv_("T", &below, &nscol, &minus, A + nscol, &nsrow, t.data(), &one, &plus, &y[k1], &one);
    }
    strsv_("L", "T", "N", &nscol, A, &nsrow, &y[k1], &one);
  }
  Eigen::VectorXd x(n);
  for (int k = 0; k < n; ++k) x[perm[k]] = static_cast<double>(y[k]);  // x = Pᵀ z
  return x;
}

}  // namespace

SingleFactor::SingleFactor(const CholmodFactor& factor) : m_factor(&factor) {
  BS_VERIFY(factor.ok(),
            "single-precision copy of a factor that is not usable: " << factor.message());
  const cholmod_factor& L = *factor.m_impl->factor;
  BS_VERIFY(L.is_super && L.is_ll && L.xtype == CHOLMOD_REAL,
            "single-precision copy needs a supernodal real LLᵀ factor");
  const auto* x = static_cast<const double*>(L.x);
  m_values.assign(x, x + L.xsize);  // each value rounded to the nearest float
  m_rows = factor.rows();
}

Eigen::VectorXd SingleFactor::solve(ConstRef<Eigen::VectorXd> b) const {
  BS_VERIFY(b.size() == m_rows,
            "right-hand side has " << b.size() << " rows, the factor " << m_rows);
  return supernodal_solve(*m_factor->m_impl->factor, m_values.data(), b);
}

SparseMatrix CholmodFactor::solve_lower_permuted(const SparseMatrix& B) const {
  BS_VERIFY(ok(), "solve_lower_permuted() on a factor that is not usable: " << m_message);
  BS_VERIFY(B.rows() == m_rows,
            "right-hand side has " << B.rows() << " rows, the factor " << m_rows);
  Impl& impl = *m_impl;
  SparseMatrix rhs = B;
  rhs.makeCompressed();
  cholmod_sparse view = sparse_view(rhs, /*stype=*/0);
  cholmod_sparse* PB = cholmod_spsolve(CHOLMOD_P, impl.factor, &view, &impl.common);
  BS_VERIFY(PB != nullptr, "CHOLMOD permutation failed (status " << impl.common.status << ")");
  cholmod_sparse* Y = cholmod_spsolve(CHOLMOD_L, impl.factor, PB, &impl.common);
  cholmod_free_sparse(&PB, &impl.common);
  BS_VERIFY(Y != nullptr, "CHOLMOD lower solve failed (status " << impl.common.status << ")");
  const Eigen::Map<const SparseMatrix> map(
      static_cast<index_t>(Y->nrow), static_cast<index_t>(Y->ncol),
      static_cast<index_t>(static_cast<const int*>(Y->p)[Y->ncol]), static_cast<const int*>(Y->p),
      static_cast<const int*>(Y->i), static_cast<const double*>(Y->x));
  SparseMatrix out = map;
  cholmod_free_sparse(&Y, &impl.common);
  return out;
}

}  // namespace brainshift::core
