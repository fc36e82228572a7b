#pragma once
/// @file
/// @brief Linear (constant-strain) tetrahedral element: shape-function gradients and the
/// isotropic linear-elastic stiffness K_e = V Bᵀ D B (12×12, mN/mm).
///
/// DOF order inside an element: (x0, y0, z0, x1, y1, z1, ..., z3).

#include "core/config.hpp"

#include <Eigen/Core>

namespace brainshift::core {

/// Rest geometry of one linear tetrahedron.
struct TetShape {
  Eigen::Matrix<double, 4, 3> grad;  ///< ∇N_k, row k = gradient of shape function k (1/mm)
  Matrix3d rest_edges_inv;           ///< Dm⁻¹ with Dm = [X1−X0, X2−X0, X3−X0] (1/mm)
  double volume = 0.0;               ///< rest volume, mm³ (> 0)
};

/// Shape data of the tetrahedron with rest nodes X (rows).
/// \throws brainshift::Error when the volume is not positive (names the volume).
TetShape tet_shape(const Eigen::Matrix<double, 4, 3>& X);

/// Isotropic elasticity matrix D (6×6, Voigt order xx, yy, zz, xy, yz, zx, engineering shear), kPa.
/// @param[in] youngs_modulus E, kPa.  @param[in] poisson_ratio nu in (−1, 0.5).
Eigen::Matrix<double, 6, 6> isotropic_elasticity(double youngs_modulus, double poisson_ratio);

/// Linear element stiffness K_e = V Bᵀ D B, symmetric PSD with the six rigid modes in its null
/// space (12×12, mN/mm).
Matrix12d linear_tet_stiffness(const TetShape& shape, double youngs_modulus, double poisson_ratio);

}  // namespace brainshift::core
