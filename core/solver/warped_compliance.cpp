#include "core/solver/warped_compliance.hpp"

#include "core/error.hpp"

namespace brainshift::core {

WarpedCompliance::WarpedCompliance(const CholmodFactor& factor, const DofMap& dofs)
    : m_factor(&factor), m_dofs(&dofs) {}

void WarpedCompliance::set_rotations(std::vector<Matrix3d> nodal_rotations) {
  BS_VERIFY(nodal_rotations.empty() ||
                static_cast<index_t>(nodal_rotations.size()) == m_dofs->num_nodes(),
            "got " << nodal_rotations.size() << " nodal rotations, expected 0 or "
                   << m_dofs->num_nodes());
  m_rotations = std::move(nodal_rotations);
}

namespace {

/// Applies R_n (or R_nᵀ when `transposed`) to each node's 3-vector of v; identity when R is empty.
Eigen::VectorXd rotate_nodes(const std::vector<Matrix3d>& R, ConstRef<Eigen::VectorXd> v,
                             bool transposed) {
  if (R.empty()) return v;
  Eigen::VectorXd out(v.size());
  for (std::size_t n = 0; n < R.size(); ++n) {
    const auto i = static_cast<Eigen::Index>(3 * n);
    out.segment<3>(i) = transposed ? Vector3d(R[n].transpose() * v.segment<3>(i))
                                   : Vector3d(R[n] * v.segment<3>(i));
  }
  return out;
}

}  // namespace

Eigen::VectorXd WarpedCompliance::rotate_transposed(ConstRef<Eigen::VectorXd> v) const {
  BS_VERIFY(v.size() == m_dofs->num_full(),
            "vector has size " << v.size() << ", expected " << m_dofs->num_full());
  return rotate_nodes(m_rotations, v, /*transposed=*/true);
}

Eigen::VectorXd WarpedCompliance::rotate(ConstRef<Eigen::VectorXd> v) const {
  BS_VERIFY(v.size() == m_dofs->num_full(),
            "vector has size " << v.size() << ", expected " << m_dofs->num_full());
  return rotate_nodes(m_rotations, v, /*transposed=*/false);
}

Eigen::VectorXd WarpedCompliance::apply(ConstRef<Eigen::VectorXd> v) const {
  // Fixed DOFs come in whole nodes, so per-node rotations never mix free and fixed DOFs.
  const Eigen::VectorXd rest_frame = m_dofs->restrict(rotate_transposed(v));
  if (m_dofs->num_free() == 0) return Eigen::VectorXd::Zero(v.size());
  const Eigen::VectorXd solved = m_factor->solve(rest_frame);
  return rotate(m_dofs->expand(solved));
}

}  // namespace brainshift::core
