#include "core/assembly/dof_map.hpp"

#include "core/error.hpp"

namespace brainshift::core {

DofMap::DofMap(index_t num_nodes, const std::vector<index_t>& fixed_nodes)
    : m_num_nodes(num_nodes) {
  BS_VERIFY(num_nodes >= 0, "number of nodes must be non-negative, got " << num_nodes);
  std::vector<bool> fixed(static_cast<std::size_t>(num_nodes), false);
  for (const index_t node : fixed_nodes) {
    BS_VERIFY(node >= 0 && node < num_nodes,
              "fixed node " << node << " is outside [0, " << num_nodes << ")");
    fixed[static_cast<std::size_t>(node)] = true;
  }
  m_free_of_full.assign(static_cast<std::size_t>(3 * num_nodes), -1);
  m_full_of_free.reserve(static_cast<std::size_t>(3 * num_nodes));
  for (index_t node = 0; node < num_nodes; ++node) {
    if (fixed[static_cast<std::size_t>(node)]) continue;
    for (index_t c = 0; c < 3; ++c) {
      m_free_of_full[static_cast<std::size_t>(3 * node + c)] =
          static_cast<index_t>(m_full_of_free.size());
      m_full_of_free.push_back(3 * node + c);
    }
  }
  m_num_free = static_cast<index_t>(m_full_of_free.size());
}

Eigen::VectorXd DofMap::restrict(ConstRef<Eigen::VectorXd> full) const {
  BS_VERIFY(full.size() == num_full(),
            "full vector has size " << full.size() << ", expected " << num_full());
  Eigen::VectorXd out(m_num_free);
  for (index_t i = 0; i < m_num_free; ++i)
    out(i) = full(m_full_of_free[static_cast<std::size_t>(i)]);
  return out;
}

Eigen::VectorXd DofMap::expand(ConstRef<Eigen::VectorXd> free) const {
  BS_VERIFY(free.size() == m_num_free,
            "free vector has size " << free.size() << ", expected " << m_num_free);
  Eigen::VectorXd out = Eigen::VectorXd::Zero(num_full());
  for (index_t i = 0; i < m_num_free; ++i)
    out(m_full_of_free[static_cast<std::size_t>(i)]) = free(i);
  return out;
}

SparseMatrix DofMap::restrict(const SparseMatrix& full) const {
  BS_VERIFY(full.rows() == num_full() && full.cols() == num_full(),
            "matrix is " << full.rows() << "×" << full.cols() << ", expected " << num_full() << "×"
                         << num_full());
  std::vector<Triplet> triplets;
  triplets.reserve(static_cast<std::size_t>(full.nonZeros()));
  for (index_t j = 0; j < full.outerSize(); ++j) {
    const index_t fj = m_free_of_full[static_cast<std::size_t>(j)];
    if (fj < 0) continue;
    for (SparseMatrix::InnerIterator it(full, j); it; ++it) {
      const index_t fi = m_free_of_full[static_cast<std::size_t>(it.row())];
      if (fi >= 0) triplets.emplace_back(fi, fj, it.value());
    }
  }
  SparseMatrix out(m_num_free, m_num_free);
  out.setFromTriplets(triplets.begin(), triplets.end());
  return out;
}

}  // namespace brainshift::core
