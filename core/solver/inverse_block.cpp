#include "core/solver/inverse_block.hpp"

#include "core/error.hpp"
#include "core/logger.hpp"
#include "core/parallel.hpp"
#include "core/solver/cholmod_views.hpp"
#include "core/timing.hpp"

#include <cholmod.h>

#include <algorithm>
#include <sstream>
#include <vector>

namespace brainshift::core {
namespace {

/// A CHOLMOD common started and finished with the scope; statuses are read, never printed.
struct Common {
  cholmod_common c{};
  Common() {
    cholmod_start(&c);
    c.print = 0;
    c.error_handler = nullptr;
  }
  ~Common() { cholmod_finish(&c); }
  Common(const Common&) = delete;
  Common& operator=(const Common&) = delete;
};

/// A CHOLMOD factor freed with the scope.
struct Factor {
  cholmod_factor* L = nullptr;
  cholmod_common* c = nullptr;
  ~Factor() {
    if (L != nullptr) cholmod_free_factor(&L, c);
  }
};

/// A symmetric (stype −1) view of the compressed lower triangle `M`.
cholmod_sparse lower_view(SparseMatrix& M) { return detail::sparse_view(M, -1); }

/// CHOLMOD's fill-reducing ordering of the interior block A_II (its symbolic analysis only).
std::vector<int> interior_ordering(const SparseMatrix& A, const std::vector<index_t>& interior) {
  const auto m = static_cast<index_t>(interior.size());
  std::vector<index_t> pos(static_cast<std::size_t>(A.rows()), -1);
  for (index_t k = 0; k < m; ++k) pos[static_cast<std::size_t>(interior[k])] = k;
  std::vector<Eigen::Triplet<double>> t;
  t.reserve(static_cast<std::size_t>(A.nonZeros()));
  for (index_t j = 0; j < A.outerSize(); ++j)
    for (SparseMatrix::InnerIterator it(A, j); it; ++it) {
      const index_t r = pos[static_cast<std::size_t>(it.row())];
      const index_t c = pos[static_cast<std::size_t>(it.col())];
      if (r >= 0 && c >= 0 && r >= c) t.emplace_back(r, c, it.value());
    }
  SparseMatrix Aii(m, m);
  Aii.setFromTriplets(t.begin(), t.end());
  Aii.makeCompressed();
  Common common;
  cholmod_sparse view = lower_view(Aii);
  Factor f{cholmod_analyze(&view, &common.c), &common.c};
  BS_VERIFY(f.L != nullptr,
            "CHOLMOD could not order the interior block (status " << common.c.status << ")");
  const auto* perm = static_cast<const int*>(f.L->Perm);
  return {perm, perm + m};
}

}  // namespace

InverseBlockResult inverse_block(const SparseMatrix& A, std::span<const index_t> indices,
                                 int threads) {
  BS_VERIFY(A.rows() == A.cols(), "inverse_block: matrix is " << A.rows() << "×" << A.cols());
  const index_t n = A.rows();
  const auto nb = static_cast<index_t>(indices.size());
  std::vector<char> in_block(static_cast<std::size_t>(n), 0);
  for (index_t s : indices) {
    BS_VERIFY(s >= 0 && s < n, "inverse_block: index " << s << " outside [0, " << n << ")");
    BS_VERIFY(!in_block[static_cast<std::size_t>(s)], "inverse_block: index " << s << " repeated");
    in_block[static_cast<std::size_t>(s)] = 1;
  }
  InverseBlockResult res;
  if (nb == 0) {
    res.ok = true;
    res.message = "ok";
    return res;
  }
  const auto t0 = Clock::now();

  // The ordering: the interior by CHOLMOD's choice, then S in the caller's order.
  std::vector<index_t> interior;
  interior.reserve(static_cast<std::size_t>(n - nb));
  for (index_t i = 0; i < n; ++i)
    if (!in_block[static_cast<std::size_t>(i)]) interior.push_back(i);
  const index_t m = n - nb;
  std::vector<int> perm;
  perm.reserve(static_cast<std::size_t>(n));
  if (m > 0)
    for (int k : interior_ordering(A, interior))
      perm.push_back(static_cast<int>(interior[static_cast<std::size_t>(k)]));
  for (index_t s : indices) perm.push_back(static_cast<int>(s));

  // The partial factorisation P A Pᵀ = L Lᵀ with the given order, not postordered (a postorder
  // could move interior columns behind S).
  Common common;
  cholmod_common& c = common.c;
  c.nmethods = 1;
  c.method[0].ordering = CHOLMOD_GIVEN;
  c.postorder = 0;
  c.supernodal = CHOLMOD_SUPERNODAL;
  SparseMatrix lower = detail::lower_triangle(A);
  cholmod_sparse view = lower_view(lower);
  Factor f{cholmod_analyze_p(&view, perm.data(), nullptr, 0, &c), &c};
  BS_VERIFY(f.L != nullptr, "inverse_block: CHOLMOD analysis failed (status " << c.status << ")");
  const auto* used = static_cast<const int*>(f.L->Perm);
  BS_VERIFY(std::equal(perm.begin(), perm.end(), used),
            "inverse_block: CHOLMOD did not keep the given ordering");
  const int factored = cholmod_factorize(&view, f.L, &c);
  if (c.status == CHOLMOD_NOT_POSDEF || (factored && f.L->minor < static_cast<std::size_t>(n))) {
    std::ostringstream msg;
    const std::size_t minor = f.L->minor;
    msg << "not positive definite: non-positive pivot at column "
        << (minor < static_cast<std::size_t>(n) ? perm[minor] : -1);
    res.message = msg.str();
    return res;
  }
  logger().debug("inverse_block: n {}, |S| {}, nnz(L) {:.3g}, flops {:.3g}, {:.2f} s", n, nb, c.lnz,
                 c.fl, seconds_since(t0));
  BS_VERIFY(factored && c.status >= CHOLMOD_OK && f.L->is_super,
            "inverse_block: CHOLMOD factorisation failed (status " << c.status << ")");

  // L_SS, the trailing block, from the supernodes that hold columns ≥ m.
  Eigen::MatrixXd Lss = Eigen::MatrixXd::Zero(nb, nb);
  const auto* super = static_cast<const int*>(f.L->super);
  const auto* pi = static_cast<const int*>(f.L->pi);
  const auto* px = static_cast<const int*>(f.L->px);
  const auto* rows = static_cast<const int*>(f.L->s);
  const auto* x = static_cast<const double*>(f.L->x);
  for (std::size_t s = 0; s < f.L->nsuper; ++s) {
    const int k1 = super[s];
    const int k2 = super[s + 1];
    if (k2 <= m) continue;
    const int nsrow = pi[s + 1] - pi[s];
    for (int j = std::max<int>(k1, static_cast<int>(m)); j < k2; ++j)
      for (int r = j - k1; r < nsrow; ++r) {
        const int row = rows[pi[s] + r];
        Lss(row - m, j - m) = x[static_cast<std::size_t>(px[s]) + static_cast<std::size_t>(r) +
                                static_cast<std::size_t>(j - k1) * static_cast<std::size_t>(nsrow)];
      }
  }
  cholmod_free_factor(&f.L, &c);  // no longer needed: free it before the dense work
  res.factor_seconds = seconds_since(t0);
  const auto t1 = Clock::now();

  // X = L_SS⁻¹ (lower triangular), in column chunks: chunk [c0, c1) solves the trailing
  // triangle from row c0 down (rows above are zero).
  constexpr index_t width = 64;
  const auto chunks = static_cast<std::size_t>((nb + width - 1) / width);
  Eigen::MatrixXd X = Eigen::MatrixXd::Zero(nb, nb);
  parallel_chunks(chunks, threads, [&](std::size_t k) {
    const index_t c0 = static_cast<index_t>(k) * width;
    const index_t w = std::min(width, nb - c0);
    Eigen::MatrixXd R = Eigen::MatrixXd::Zero(nb - c0, w);
    R.topRows(w).setIdentity();
    Lss.bottomRightCorner(nb - c0, nb - c0).triangularView<Eigen::Lower>().solveInPlace(R);
    X.block(c0, c0, nb - c0, w) = R;
  });
  Lss.resize(0, 0);
  // (A⁻¹)_SS = Xᵀ X: column chunk [c0, c1), rows ≥ c0 (X's columns a ≥ c0 vanish above row a).
  Eigen::MatrixXd& C = res.block;
  C = Eigen::MatrixXd::Zero(nb, nb);
  parallel_chunks(chunks, threads, [&](std::size_t k) {
    const index_t c0 = static_cast<index_t>(k) * width;
    const index_t w = std::min(width, nb - c0);
    C.block(c0, c0, nb - c0, w).noalias() =
        X.bottomRightCorner(nb - c0, nb - c0).transpose().triangularView<Eigen::Upper>() *
        X.block(c0, c0, nb - c0, w);
  });
  for (index_t j = 0; j < nb; ++j)
    for (index_t i = j + 1; i < nb; ++i) C(j, i) = C(i, j);
  res.inverse_seconds = seconds_since(t1);
  res.ok = C.allFinite();
  res.message = res.ok ? "ok" : "the inverse is not finite";
  if (!res.ok) C.resize(0, 0);
  return res;
}

}  // namespace brainshift::core
