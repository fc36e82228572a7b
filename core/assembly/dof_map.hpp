#pragma once
/// @file
/// @brief Map between the full DOF vector (3N, node-major) and the free DOFs that remain after
/// Dirichlet elimination of fixed nodes.

#include "core/config.hpp"

#include <vector>

namespace brainshift::core {

class DofMap {
 public:
  DofMap() = default;
  /// @param[in] num_nodes N.  @param[in] fixed_nodes nodes whose three DOFs are eliminated
  /// (duplicates allowed). \throws brainshift::Error on an index outside [0, N).
  DofMap(index_t num_nodes, const std::vector<index_t>& fixed_nodes);

  [[nodiscard]] index_t num_nodes() const { return m_num_nodes; }
  [[nodiscard]] index_t num_full() const { return 3 * m_num_nodes; }
  [[nodiscard]] index_t num_free() const { return m_num_free; }
  /// Free index of full DOF `dof`, or −1 when the DOF is fixed.
  [[nodiscard]] index_t free_index(index_t dof) const { return m_free_of_full[dof]; }
  [[nodiscard]] bool is_fixed_node(index_t node) const { return m_free_of_full[3 * node] < 0; }
  /// Full DOF of free index `i`.
  [[nodiscard]] index_t full_index(index_t i) const { return m_full_of_free[i]; }

  /// Free part of a full vector (3N → F).
  [[nodiscard]] Eigen::VectorXd restrict(ConstRef<Eigen::VectorXd> full) const;
  /// Full vector from free values, zero on fixed DOFs (F → 3N).
  [[nodiscard]] Eigen::VectorXd expand(ConstRef<Eigen::VectorXd> free) const;
  /// K_ff: rows and columns of the free DOFs of a full 3N×3N matrix.
  [[nodiscard]] SparseMatrix restrict(const SparseMatrix& full) const;

 private:
  index_t m_num_nodes = 0;
  index_t m_num_free = 0;
  std::vector<index_t> m_free_of_full;
  std::vector<index_t> m_full_of_free;
};

}  // namespace brainshift::core
