#include "core/fem/rotation.hpp"

#include "core/error.hpp"

#include <Eigen/SVD>

#include <cmath>

namespace brainshift::core {

namespace {

/// R = U Vᵀ from the SVD of M, with U's column of the smallest singular value negated when
/// det(U Vᵀ) < 0, so det R = +1. JacobiSVD is well defined for any finite M (including 0 and
/// rank-deficient M, where U and V are still orthogonal), so R is always finite.
Matrix3d svd_polar_rotation(const Matrix3d& M) {
  const Eigen::JacobiSVD<Matrix3d> svd(M, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Matrix3d U = svd.matrixU();
  const Matrix3d& V = svd.matrixV();
  if (U.determinant() * V.determinant() < 0.0) {
    U.col(2) = -U.col(2);  // singular values are sorted decreasingly: column 2 is the smallest
  }
  return U * V.transpose();
}

/// The orthogonal polar factor by Newton's iteration X ← ½(γX + (γX)⁻ᵀ) with Higham's scaling
/// γ = (‖X⁻¹‖_F / ‖X‖_F)^½ (Higham, "Computing the polar decomposition", 1986): quadratic
/// convergence, about five 3×3 inverses for the strains of brain tissue — an order of magnitude
/// cheaper than a Jacobi SVD, which this replaces on the hot path (one call per element per
/// iteration). Used only when M is safely non-singular with det M > 0 (then the factor is the
/// proper rotation); returns false otherwise, or if it does not converge, and the SVD decides.
bool newton_polar_rotation(const Matrix3d& M, Matrix3d& R) {
  const double largest = M.cwiseAbs().maxCoeff();
  if (!(largest > 0.0)) return false;
  Matrix3d X = M * std::ldexp(1.0, -std::ilogb(largest));  // exact power-of-two scaling
  const double det = X.determinant();
  const double norm = X.norm();
  // det / (‖X‖_F/√3)³ is 1 for a scaled rotation and → 0 as X degenerates (≈ 1/cond² for a
  // stretch); below 1e-4 the SVD is the safer tool (and inverted elements need its sign fix).
  if (!(det > 1e-4 * norm * norm * norm / (3.0 * std::sqrt(3.0)))) return false;
  for (int k = 0; k < 30; ++k) {
    const Matrix3d Xi = X.inverse();
    const double gamma = k < 6 ? std::sqrt(std::sqrt(Xi.squaredNorm() / X.squaredNorm())) : 1.0;
    const Matrix3d next = 0.5 * (gamma * X + Xi.transpose() / gamma);
    const double change = (next - X).squaredNorm();
    X = next;
    // The convergence is quadratic, ‖X_{k+1} − R‖ ≤ ½‖X_k⁻¹‖₂‖X_k − R‖² (Higham 1986, eq. 3.3),
    // and the change is X_k's error to first order: once it is below 1e-8 the new X is within
    // ≈ 5e-17 of R, at round-off, and a further step would only confirm it (one 3×3 inverse of
    // the usual five saved). The orthogonality check below still decides.
    if (change < 1e-16) break;
  }
  if (!X.allFinite() || (X.transpose() * X - Matrix3d::Identity()).norm() > 1e-14) return false;
  R = X;
  return true;
}

Matrix3d proper_polar_rotation(const Matrix3d& M) {
  Matrix3d R;
  if (newton_polar_rotation(M, R)) return R;
  return svd_polar_rotation(M);
}

}  // namespace

Matrix3d rotation_from_deformation_gradient(const Matrix3d& F, bool* inverted) {
  BS_VERIFY(F.allFinite(), "deformation gradient is not finite:\n" << F);
  if (inverted != nullptr) {
    // Scale by a power of two (exact) so det F neither underflows nor overflows: its sign is
    // then that of the determinant of F itself, at any magnitude (1e-150 I is not inverted).
    const double largest = F.cwiseAbs().maxCoeff();
    *inverted = largest == 0.0 || (F * std::ldexp(1.0, -std::ilogb(largest))).determinant() <= 0.0;
  }
  return proper_polar_rotation(F);
}

Matrix3d nearest_rotation(const Matrix3d& M) {
  BS_VERIFY(M.allFinite(), "matrix to orthonormalise is not finite:\n" << M);
  return proper_polar_rotation(M);
}

}  // namespace brainshift::core
