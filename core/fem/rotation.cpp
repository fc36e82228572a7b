#include "core/fem/rotation.hpp"

#include <Eigen/SVD>
#include <cmath>

#include "core/error.hpp"

namespace brainshift::core {

namespace {

/// R = U Vᵀ from the SVD of M, with U's column of the smallest singular value negated when
/// det(U Vᵀ) < 0, so det R = +1. JacobiSVD is well defined for any finite M (including 0 and
/// rank-deficient M, where U and V are still orthogonal), so R is always finite.
Matrix3d proper_polar_rotation(const Matrix3d& M) {
  const Eigen::JacobiSVD<Matrix3d> svd(M, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Matrix3d U = svd.matrixU();
  const Matrix3d& V = svd.matrixV();
  if (U.determinant() * V.determinant() < 0.0) {
    U.col(2) = -U.col(2);  // singular values are sorted decreasingly: column 2 is the smallest
  }
  return U * V.transpose();
}

}  // namespace

Matrix3d rotation_from_deformation_gradient(const Matrix3d& F, bool* inverted) {
  BS_VERIFY(F.allFinite(), "deformation gradient is not finite:\n" << F);
  if (inverted != nullptr) {
    // Scale by a power of two (exact) so det F neither underflows nor overflows: its sign is
    // then that of the determinant of F itself, at any magnitude (1e-150 I is not inverted).
    const double largest = F.cwiseAbs().maxCoeff();
    *inverted = largest == 0.0 ||
                (F * std::ldexp(1.0, -std::ilogb(largest))).determinant() <= 0.0;
  }
  return proper_polar_rotation(F);
}

Matrix3d nearest_rotation(const Matrix3d& M) {
  BS_VERIFY(M.allFinite(), "matrix to orthonormalise is not finite:\n" << M);
  return proper_polar_rotation(M);
}

}  // namespace brainshift::core
