#pragma once
/// @file
/// @brief Compliance warping (Saupin et al. 2008; seed 002 §3.3.3): the compliance used on the
/// intra-operative path is C(R) = R K0⁻¹ Rᵀ, with R = diag(R_1 … R_N) the nodal rotations and
/// K0⁻¹ the inverse of the rest stiffness with Dirichlet DOFs eliminated (zero rows/columns there).

#include "core/assembly/dof_map.hpp"
#include "core/config.hpp"
#include "core/solver/cholmod_factor.hpp"

#include <vector>

namespace brainshift::core {

/// Applies R K0⁻¹ Rᵀ with the pre-computed factor of K0_ff.
class WarpedCompliance {
 public:
  /// @param[in] factor  factor of the free-free block of K0. Not owned; must outlive this object.
  /// @param[in] dofs    the DOF map that block was built with. Not owned; must outlive this object.
  WarpedCompliance(const CholmodFactor& factor, const DofMap& dofs);

  /// Sets the nodal rotations (#N proper rotations). An empty vector means R = I (unwarped K0⁻¹).
  void set_rotations(std::vector<Matrix3d> nodal_rotations);
  [[nodiscard]] const std::vector<Matrix3d>& rotations() const { return m_rotations; }

  /// R K0⁻¹ Rᵀ v for a full vector v (3N, mN) → displacement (3N, mm), zero on fixed DOFs.
  [[nodiscard]] Eigen::VectorXd apply(ConstRef<Eigen::VectorXd> v) const;
  /// Rᵀ v (3N): rotates each node's 3-vector into the rest frame.
  [[nodiscard]] Eigen::VectorXd rotate_transposed(ConstRef<Eigen::VectorXd> v) const;
  /// R v (3N).
  [[nodiscard]] Eigen::VectorXd rotate(ConstRef<Eigen::VectorXd> v) const;

  [[nodiscard]] const CholmodFactor& factor() const { return *m_factor; }
  [[nodiscard]] const DofMap& dofs() const { return *m_dofs; }

 private:
  const CholmodFactor* m_factor;  // not owned
  const DofMap* m_dofs;           // not owned
  std::vector<Matrix3d> m_rotations;
};

}  // namespace brainshift::core
