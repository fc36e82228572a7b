#include "constraints/solver/compliance_operator.hpp"

#include "core/assembly/stiffness_assembly.hpp"
#include "core/error.hpp"
#include "core/hash.hpp"
#include "core/logger.hpp"
#include "core/parallel.hpp"
#include "core/solver/inverse_block.hpp"

#include <algorithm>
#include <exception>
#include <vector>

namespace brainshift::constraints {

namespace {

/// Calls fn(row, node, h) for every node a row of H (#rows × 3N) touches, with h the row's
/// 3-vector on that node's DOFs.
template <typename Fn>
void for_each_row_node(const SparseMatrix& H, Fn&& fn) {
  const SparseMatrix Ht = H.transpose();  // 3N × m: column i = row i of H, sorted by DOF
  for (int i = 0; i < Ht.outerSize(); ++i) {
    Vector3d h = Vector3d::Zero();
    index_t node = -1;
    for (SparseMatrix::InnerIterator it(Ht, i); it; ++it) {
      const auto n = static_cast<index_t>(it.row() / 3);
      if (n != node) {
        if (node >= 0) fn(static_cast<index_t>(i), node, h);
        node = n;
        h.setZero();
      }
      h[it.row() % 3] = it.value();
    }
    if (node >= 0) fn(static_cast<index_t>(i), node, h);
  }
}

}  // namespace

std::uint64_t stiffness_fingerprint(const core::TetMesh& mesh, std::vector<index_t> fixed_nodes) {
  std::sort(fixed_nodes.begin(), fixed_nodes.end());
  fixed_nodes.erase(std::unique(fixed_nodes.begin(), fixed_nodes.end()), fixed_nodes.end());
  using core::fnv1a;
  const std::int64_t sizes[2] = {mesh.num_nodes(), mesh.num_tets()};
  std::uint64_t h = fnv1a(sizes, sizeof sizes);
  h = fnv1a(mesh.nodes().data(), sizeof(double) * static_cast<std::size_t>(mesh.nodes().size()), h);
  h = fnv1a(mesh.tets().data(),
            sizeof(mesh.tets()(0, 0)) * static_cast<std::size_t>(mesh.tets().size()), h);
  h = fnv1a(mesh.youngs_modulus().data(),
            sizeof(double) * static_cast<std::size_t>(mesh.youngs_modulus().size()), h);
  h = fnv1a(mesh.poisson_ratio().data(),
            sizeof(double) * static_cast<std::size_t>(mesh.poisson_ratio().size()), h);
  return fnv1a(fixed_nodes.data(), sizeof(index_t) * fixed_nodes.size(), h);
}

std::string to_string(ComplianceStrategy s) {
  return core::enum_to_string(s);  // the option table's names (visit_fields)
}

std::string to_string(BlockPrecompute m) {
  return core::enum_to_string(m);  // the option table's names (visit_fields)
}

ComplianceOperator::ComplianceOperator(const core::CholmodFactor& factor, const core::DofMap& dofs,
                                       std::vector<index_t> block_nodes,
                                       const ComplianceOptions& options, std::uint64_t fingerprint,
                                       const SparseMatrix* factorised)
    : m_factor(&factor),
      m_dofs(&dofs),
      m_warp(factor, dofs),
      m_block_nodes(std::move(block_nodes)),
      m_fingerprint(fingerprint) {
  BS_VERIFY(factor.ok(), "compliance operator needs a factorised K0: " << factor.message());
  if (options.single_precision_solves && factor.rows() > 0 &&
      factor.factor_nonzeros() * sizeof(double) >= options.single_precision_min_bytes)
    m_single = std::make_unique<const core::SingleFactor>(factor);
  logger().debug("K0's factor: nnz(L) {} ({} MiB in double); the steps solve in {}",
                 factor.factor_nonzeros(), (factor.factor_nonzeros() * sizeof(double)) >> 20,
                 m_single ? "float" : "double");
  std::sort(m_block_nodes.begin(), m_block_nodes.end());
  m_block_nodes.erase(std::unique(m_block_nodes.begin(), m_block_nodes.end()), m_block_nodes.end());
  for (index_t n : m_block_nodes)
    BS_VERIFY(n >= 0 && n < dofs.num_nodes(),
              "compliance block node " << n << " outside [0, " << dofs.num_nodes() << ")");
  const std::size_t nb = 3 * m_block_nodes.size();
  const std::size_t bytes = nb * nb * sizeof(double);
  const bool fits = bytes <= options.memory_budget_bytes && !m_block_nodes.empty();
  switch (options.strategy) {
    case ComplianceStrategy::DENSE_BLOCK:
      BS_VERIFY(!m_block_nodes.empty(),
                "dense compliance block requested but no block nodes given");
      BS_VERIFY(bytes <= options.memory_budget_bytes,
                "dense compliance block needs " << bytes / (1 << 20) << " MiB, over the budget of "
                                                << options.memory_budget_bytes / (1 << 20)
                                                << " MiB");
      m_strategy = ComplianceStrategy::DENSE_BLOCK;
      break;
    case ComplianceStrategy::SPARSE_SOLVE:
      m_strategy = ComplianceStrategy::SPARSE_SOLVE;
      break;
    case ComplianceStrategy::AUTO:
      m_strategy = fits ? ComplianceStrategy::DENSE_BLOCK : ComplianceStrategy::SPARSE_SOLVE;
      break;
  }
  if (m_strategy != ComplianceStrategy::DENSE_BLOCK) return;

  m_block_pos.assign(static_cast<std::size_t>(dofs.num_nodes()), -1);
  for (std::size_t b = 0; b < m_block_nodes.size(); ++b)
    m_block_pos[m_block_nodes[b]] = static_cast<index_t>(b);
  std::vector<index_t> free_of_block(nb);  // free index of each block DOF, −1 if fixed
  for (std::size_t a = 0; a < nb; ++a)
    free_of_block[a] = dofs.free_index(3 * m_block_nodes[a / 3] + static_cast<index_t>(a % 3));

  m_cache_status = "computed";
  if (options.precomputed) {
    const std::string why = check_precomputed(*options.precomputed, free_of_block);
    if (why.empty()) {
      m_adopted = options.precomputed;  // shared, not copied: the cache's matrix is the block
      m_cache_status = "adopted";
      logger().info("compliance block: {} nodes adopted from the precomputed cache",
                    m_block_nodes.size());
      return;
    }
    m_cache_status = "rejected (" + why + "); computed";
    logger().warn("precomputed compliance block not used: {}; computing it", why);
  }

  // Precompute C = K0_ff⁻¹ on the block DOFs.
  m_block = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(nb), static_cast<Eigen::Index>(nb));
  std::vector<index_t> cols;  // block DOFs that are free
  for (std::size_t a = 0; a < nb; ++a)
    if (free_of_block[a] >= 0) cols.push_back(static_cast<index_t>(a));
  // By one factorisation with the block DOFs ordered last (core/solver/inverse_block.hpp): the
  // trailing factor's inverse. Falls back to unit solves if that factorisation fails.
  const bool partial = options.precompute == BlockPrecompute::PARTIAL_FACTORISATION ||
                       (options.precompute == BlockPrecompute::AUTO &&
                        4 * cols.size() <= static_cast<std::size_t>(dofs.num_free()));
  if (partial && factorised != nullptr) {
    BS_VERIFY(factorised->rows() == dofs.num_free() && factorised->cols() == dofs.num_free(),
              "factorised matrix is " << factorised->rows() << "×" << factorised->cols() << " for "
                                      << dofs.num_free() << " free DOFs");
    std::vector<index_t> free_dofs;
    free_dofs.reserve(cols.size());
    for (index_t a : cols) free_dofs.push_back(free_of_block[static_cast<std::size_t>(a)]);
    core::InverseBlockResult inv =
        core::inverse_block(*factorised, free_dofs, std::max(1, options.precompute_threads));
    if (inv.ok) {
      for (std::size_t j = 0; j < cols.size(); ++j)
        for (std::size_t i = 0; i < cols.size(); ++i)
          m_block(cols[i], cols[j]) =
              inv.block(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j));
      logger().info(
          "compliance block: {} nodes, {} MiB (partial factorisation {:.2f} s, inverse {:.2f} s)",
          m_block_nodes.size(), bytes >> 20, inv.factor_seconds, inv.inverse_seconds);
      return;
    }
    logger().warn("compliance block: the partial factorisation failed ({}); unit solves instead",
                  inv.message);
  }
  // By unit right-hand sides, in chunks.
  // Chunks are independent (each writes its own columns), each solved with its own CHOLMOD
  // workspace (solve_concurrent); every chunk is the same solve as with one thread.
  const auto chunk = static_cast<std::size_t>(std::max(1, options.precompute_chunk));
  const std::size_t chunks = (cols.size() + chunk - 1) / chunk;
  const auto solve_chunk = [&](std::size_t c) {
    const std::size_t c0 = c * chunk;
    const auto nc = static_cast<Eigen::Index>(std::min<std::size_t>(chunk, cols.size() - c0));
    Eigen::MatrixXd rhs = Eigen::MatrixXd::Zero(dofs.num_free(), nc);
    for (Eigen::Index j = 0; j < nc; ++j) rhs(free_of_block[cols[c0 + j]], j) = 1.0;
    const Eigen::MatrixXd sol = factor.solve_concurrent(rhs);
    for (Eigen::Index j = 0; j < nc; ++j)
      for (std::size_t a = 0; a < nb; ++a)
        if (free_of_block[a] >= 0)
          m_block(static_cast<Eigen::Index>(a), cols[c0 + j]) = sol(free_of_block[a], j);
  };
  core::parallel_chunks(chunks, options.precompute_threads, solve_chunk);
  // K0⁻¹ is symmetric; the solves are to ≈1e-16 relative. Make the block exactly symmetric so a
  // cache that stores one triangle gives back the very same matrix (the loop's answer may depend
  // on the last bit of W).
  for (Eigen::Index j = 0; j < m_block.cols(); ++j)
    for (Eigen::Index i = j + 1; i < m_block.rows(); ++i)
      m_block(i, j) = m_block(j, i) = 0.5 * (m_block(i, j) + m_block(j, i));
  logger().info("compliance block: {} nodes, {} MiB", m_block_nodes.size(), bytes >> 20);
}

std::string ComplianceOperator::check_precomputed(const ComplianceBlock& b,
                                                  const std::vector<index_t>& free_of_block) const {
  if (m_fingerprint == 0 || b.fingerprint != m_fingerprint)
    return "made for another mesh, material or set of fixed nodes";
  if (b.nodes != m_block_nodes) return "made for other block nodes (vessels or surface changed)";
  const auto nb = static_cast<Eigen::Index>(free_of_block.size());
  if (b.matrix.rows() != nb || b.matrix.cols() != nb) return "wrong size";
  if (!b.matrix.allFinite()) return "not finite";
  // Two columns against fresh solves: the fingerprint cannot see a corrupted payload or a change
  // in how K0 is assembled. First and middle free block DOFs; relative agreement to 1e-8 (solves
  // agree to ≈1e-14 relative; a block from another model disagrees at O(1)).
  std::vector<Eigen::Index> probe;
  for (Eigen::Index a : {Eigen::Index{0}, nb / 2})
    for (Eigen::Index k = a; k < nb; ++k)
      if (free_of_block[static_cast<std::size_t>(k)] >= 0) {
        probe.push_back(k);
        break;
      }
  Eigen::MatrixXd rhs =
      Eigen::MatrixXd::Zero(m_dofs->num_free(), static_cast<Eigen::Index>(probe.size()));
  for (std::size_t j = 0; j < probe.size(); ++j)
    rhs(free_of_block[static_cast<std::size_t>(probe[j])], static_cast<Eigen::Index>(j)) = 1.0;
  const Eigen::MatrixXd sol = m_factor->solve(rhs);
  for (std::size_t j = 0; j < probe.size(); ++j) {
    Eigen::VectorXd fresh = Eigen::VectorXd::Zero(nb);
    for (Eigen::Index a = 0; a < nb; ++a)
      if (free_of_block[static_cast<std::size_t>(a)] >= 0)
        fresh[a] = sol(free_of_block[static_cast<std::size_t>(a)], static_cast<Eigen::Index>(j));
    const double err = (b.matrix.col(probe[j]) - fresh).norm();
    if (!(err <= 1e-8 * fresh.norm())) return "its values disagree with the factorised stiffness";
  }
  return {};
}

double ComplianceOperator::block_trace(index_t node) const {
  const Eigen::MatrixXd& C = block_matrix();
  if (C.size() == 0 || node < 0 || node >= static_cast<index_t>(m_block_pos.size())) return -1.0;
  const index_t b = m_block_pos[static_cast<std::size_t>(node)];
  if (b < 0) return -1.0;
  return C(3 * b, 3 * b) + C(3 * b + 1, 3 * b + 1) + C(3 * b + 2, 3 * b + 2);
}

std::size_t ComplianceOperator::block_bytes() const {
  return static_cast<std::size_t>(block_matrix().size()) * sizeof(double);
}

void ComplianceOperator::set_rotations(std::vector<Matrix3d> nodal_rotations) {
  m_warp.set_rotations(std::move(nodal_rotations));
}

Eigen::VectorXd ComplianceOperator::apply(ConstRef<Eigen::VectorXd> v) const {
  return m_warp.apply(v);
}

Eigen::VectorXd ComplianceOperator::apply(ConstRef<Eigen::VectorXd> v,
                                          const std::vector<Matrix3d>& R) const {
  BS_VERIFY(v.size() == m_dofs->num_full(),
            "vector has size " << v.size() << ", expected " << m_dofs->num_full());
  BS_VERIFY(R.empty() || static_cast<index_t>(R.size()) == m_dofs->num_nodes(),
            "got " << R.size() << " nodal rotations, expected 0 or " << m_dofs->num_nodes());
  if (m_dofs->num_free() == 0) return Eigen::VectorXd::Zero(v.size());
  Eigen::VectorXd w = v;
  if (!R.empty())
    for (std::size_t n = 0; n < R.size(); ++n)
      w.segment<3>(3 * static_cast<Eigen::Index>(n)) =
          R[n].transpose() * v.segment<3>(3 * static_cast<Eigen::Index>(n));
  const Eigen::VectorXd rhs = m_dofs->restrict(w);
  Eigen::VectorXd out = m_dofs->expand(m_single ? m_single->solve(rhs) : m_factor->solve(rhs));
  if (!R.empty())
    for (std::size_t n = 0; n < R.size(); ++n) {
      const Vector3d a = out.segment<3>(3 * static_cast<Eigen::Index>(n));
      out.segment<3>(3 * static_cast<Eigen::Index>(n)) = R[n] * a;
    }
  return out;
}

Eigen::MatrixXd ComplianceOperator::apply_columns(ConstRef<Eigen::MatrixXd> V,
                                                  const std::vector<Matrix3d>& R) const {
  BS_VERIFY(V.rows() == m_dofs->num_full(),
            "vectors have size " << V.rows() << ", expected " << m_dofs->num_full());
  BS_VERIFY(R.empty() || static_cast<index_t>(R.size()) == m_dofs->num_nodes(),
            "got " << R.size() << " nodal rotations, expected 0 or " << m_dofs->num_nodes());
  Eigen::MatrixXd out = Eigen::MatrixXd::Zero(V.rows(), V.cols());
  if (m_dofs->num_free() == 0 || V.cols() == 0) return out;
  Eigen::MatrixXd rhs(m_dofs->num_free(), V.cols());
  for (Eigen::Index j = 0; j < V.cols(); ++j) {
    Eigen::VectorXd w = V.col(j);
    if (!R.empty())
      for (std::size_t n = 0; n < R.size(); ++n)
        w.segment<3>(3 * static_cast<Eigen::Index>(n)) =
            R[n].transpose() * V.col(j).segment<3>(3 * static_cast<Eigen::Index>(n));
    rhs.col(j) = m_dofs->restrict(w);
  }
  const Eigen::MatrixXd sol = m_factor->solve(rhs);
  for (Eigen::Index j = 0; j < V.cols(); ++j) {
    out.col(j) = m_dofs->expand(Eigen::VectorXd(sol.col(j)));
    if (!R.empty())
      for (std::size_t n = 0; n < R.size(); ++n) {
        const Vector3d a = out.col(j).segment<3>(3 * static_cast<Eigen::Index>(n));
        out.col(j).segment<3>(3 * static_cast<Eigen::Index>(n)) = R[n] * a;
      }
  }
  return out;
}

Eigen::VectorXd ComplianceOperator::apply_block(ConstRef<Eigen::VectorXd> v,
                                                const std::vector<Matrix3d>& R) const {
  BS_VERIFY(m_strategy == ComplianceStrategy::DENSE_BLOCK,
            "no dense compliance block was precomputed");
  BS_VERIFY(v.size() == m_dofs->num_full(),
            "vector has size " << v.size() << ", expected " << m_dofs->num_full());
  BS_VERIFY(R.empty() || static_cast<index_t>(R.size()) == m_dofs->num_nodes(),
            "got " << R.size() << " nodal rotations, expected 0 or " << m_dofs->num_nodes());
  // w = Rᵀ v on the block DOFs; out_b = C w over the columns where w ≠ 0 (the rows' nodes only).
  const auto nb = static_cast<Eigen::Index>(3 * m_block_nodes.size());
  Eigen::VectorXd out_b = Eigen::VectorXd::Zero(nb);
  for (std::size_t b = 0; b < m_block_nodes.size(); ++b) {
    const Eigen::Index n = m_block_nodes[b];
    const Vector3d f = v.segment<3>(3 * n);
    if (f.isZero()) continue;
    const Vector3d w = R.empty() ? f : Vector3d(R[static_cast<std::size_t>(n)].transpose() * f);
    for (int c = 0; c < 3; ++c)
      if (w[c] != 0.0) out_b += w[c] * block_matrix().col(3 * static_cast<Eigen::Index>(b) + c);
  }
  Eigen::VectorXd out = Eigen::VectorXd::Zero(v.size());
  for (std::size_t b = 0; b < m_block_nodes.size(); ++b) {
    const Eigen::Index n = m_block_nodes[b];
    const Vector3d a = out_b.segment<3>(3 * static_cast<Eigen::Index>(b));
    out.segment<3>(3 * n) = R.empty() ? a : Vector3d(R[static_cast<std::size_t>(n)] * a);
  }
  return out;
}

bool ComplianceOperator::covers(const SparseMatrix& H) const {
  if (m_strategy != ComplianceStrategy::DENSE_BLOCK) return false;
  for (int k = 0; k < H.outerSize(); ++k)
    for (SparseMatrix::InnerIterator it(H, k); it; ++it) {
      const auto node = static_cast<index_t>(it.col() / 3);
      if (m_block_pos[static_cast<std::size_t>(node)] < 0 && !m_dofs->is_fixed_node(node))
        return false;
    }
  return true;
}

Eigen::MatrixXd ComplianceOperator::delassus(const SparseMatrix& H) const {
  return delassus(H, m_warp.rotations());
}

Eigen::MatrixXd ComplianceOperator::delassus(const SparseMatrix& H, const std::vector<Matrix3d>& R,
                                             bool* used_fallback) const {
  if (used_fallback) *used_fallback = false;
  if (m_strategy == ComplianceStrategy::DENSE_BLOCK) {
    if (covers(H)) return delassus_dense_block(H, R);
    ++m_fallbacks;
    if (used_fallback) *used_fallback = true;
    logger().debug("constraint rows touch nodes outside the compliance block; sparse fallback");
  }
  return delassus_sparse(H, R);
}

SparseMatrix ComplianceOperator::rotated_transposed_free(const SparseMatrix& H,
                                                         const std::vector<Matrix3d>& R) const {
  // Row i of H R at node n is h_{i,n}ᵀ R_n, i.e. the column vector R_nᵀ h_{i,n}.
  std::vector<Triplet> trip;
  trip.reserve(static_cast<std::size_t>(H.nonZeros()) * 3);
  for_each_row_node(H, [&](index_t i, index_t node, const Vector3d& h) {
    const Vector3d g = R.empty() ? h : Vector3d(R[node].transpose() * h);
    for (int c = 0; c < 3; ++c) {
      const index_t f = m_dofs->free_index(3 * node + c);
      if (f >= 0 && g[c] != 0.0) trip.emplace_back(f, i, g[c]);
    }
  });
  SparseMatrix G(m_dofs->num_free(), H.rows());
  G.setFromTriplets(trip.begin(), trip.end());
  return G;
}

Eigen::MatrixXd ComplianceOperator::delassus_sparse(const SparseMatrix& H) const {
  return delassus_sparse(H, m_warp.rotations());
}

Eigen::MatrixXd ComplianceOperator::delassus_sparse(const SparseMatrix& H,
                                                    const std::vector<Matrix3d>& R) const {
  BS_VERIFY(H.cols() == m_dofs->num_full(), "constraint Jacobian has "
                                                << H.cols() << " columns for " << m_dofs->num_full()
                                                << " DOFs");
  BS_VERIFY(R.empty() || static_cast<index_t>(R.size()) == m_dofs->num_nodes(),
            "got " << R.size() << " nodal rotations, expected 0 or " << m_dofs->num_nodes());
  const SparseMatrix G = rotated_transposed_free(H, R);
  const SparseMatrix Y = m_factor->solve_lower_permuted(G);
  m_last_sparse_bytes = static_cast<std::size_t>(Y.nonZeros()) * (sizeof(double) + sizeof(index_t));
  const SparseMatrix Yt = Y.transpose();
  return Eigen::MatrixXd(Yt * Y);
}

Eigen::MatrixXd ComplianceOperator::delassus_dense_block(const SparseMatrix& H) const {
  return delassus_dense_block(H, m_warp.rotations());
}

Eigen::MatrixXd ComplianceOperator::delassus_dense_block(const SparseMatrix& H,
                                                         const std::vector<Matrix3d>& R) const {
  BS_VERIFY(m_strategy == ComplianceStrategy::DENSE_BLOCK,
            "no dense compliance block was precomputed");
  BS_VERIFY(H.cols() == m_dofs->num_full(), "constraint Jacobian has "
                                                << H.cols() << " columns for " << m_dofs->num_full()
                                                << " DOFs");
  BS_VERIFY(R.empty() || static_cast<index_t>(R.size()) == m_dofs->num_nodes(),
            "got " << R.size() << " nodal rotations, expected 0 or " << m_dofs->num_nodes());
  const auto m = H.rows();
  // Per row: list of (block dof, coefficient) of H R restricted to the block.
  std::vector<std::vector<std::pair<index_t, double>>> g(static_cast<std::size_t>(m));
  const Eigen::MatrixXd& C = block_matrix();
  std::vector<char> used(static_cast<std::size_t>(C.rows()), 0);
  for_each_row_node(H, [&](index_t i, index_t node, const Vector3d& h) {
    const index_t b = m_block_pos[node];
    if (b < 0) {
      BS_VERIFY(m_dofs->is_fixed_node(node), "constraint row " << i << " touches node " << node
                                                               << ", outside the compliance block");
      return;  // fixed node: zero compliance
    }
    const Vector3d v = R.empty() ? h : Vector3d(R[node].transpose() * h);
    for (int c = 0; c < 3; ++c)
      if (v[c] != 0.0) {
        g[i].emplace_back(3 * b + c, v[c]);
        used[3 * b + c] = 1;
      }
  });
  // Compact the block DOFs the rows use: T = C[U, ·] Gᵀ (|U| × m), then W = G_U T.
  std::vector<index_t> u_of_block(used.size(), -1);
  std::vector<index_t> u_dofs;
  for (std::size_t a = 0; a < used.size(); ++a)
    if (used[a]) {
      u_of_block[a] = static_cast<index_t>(u_dofs.size());
      u_dofs.push_back(static_cast<index_t>(a));
    }
  const auto nu = static_cast<Eigen::Index>(u_dofs.size());
  Eigen::MatrixXd T = Eigen::MatrixXd::Zero(nu, m);
  for (Eigen::Index i = 0; i < m; ++i) {
    double* t = T.col(i).data();
    for (const auto& [dof, coef] : g[i]) {
      const double* c = C.col(dof).data();
      for (Eigen::Index u = 0; u < nu; ++u) t[u] += coef * c[u_dofs[u]];
    }
  }
  Eigen::MatrixXd W(m, m);
  for (Eigen::Index j = 0; j < m; ++j)
    for (Eigen::Index i = j; i < m; ++i) {
      double s = 0;
      for (const auto& [dof, coef] : g[i]) s += coef * T(u_of_block[dof], j);
      W(i, j) = s;
      W(j, i) = s;
    }
  return W;
}

Eigen::MatrixXd exact_delassus(const core::CorotationalModel& model, const core::DofMap& dofs,
                               const std::vector<Matrix3d>& element_rotations,
                               const SparseMatrix& H) {
  const SparseMatrix K = dofs.restrict(core::assemble_rotated_stiffness(model, element_rotations));
  core::CholmodFactor f;
  if (f.compute(K) != core::FactorStatus::OK) return {};
  Eigen::MatrixXd Hf(dofs.num_free(), H.rows());
  const SparseMatrix Ht = H.transpose();
  for (index_t i = 0; i < H.rows(); ++i) {
    Eigen::VectorXd col = Eigen::VectorXd(Ht.col(i));
    Hf.col(i) = dofs.restrict(col);
  }
  const Eigen::MatrixXd X = f.solve(Hf);
  return Hf.transpose() * X;
}

}  // namespace brainshift::constraints
