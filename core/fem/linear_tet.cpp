#include "core/fem/linear_tet.hpp"

#include "core/error.hpp"

#include <Eigen/LU>

#include <cmath>

namespace brainshift::core {

TetShape tet_shape(const Eigen::Matrix<double, 4, 3>& X) {
  BS_VERIFY(X.allFinite(), "tetrahedron has a non-finite rest coordinate:\n" << X);
  Matrix3d Dm;
  Dm.col(0) = (X.row(1) - X.row(0)).transpose();
  Dm.col(1) = (X.row(2) - X.row(0)).transpose();
  Dm.col(2) = (X.row(3) - X.row(0)).transpose();
  TetShape shape;
  shape.volume = Dm.determinant() / 6.0;
  BS_VERIFY(shape.volume > 0.0 && std::isfinite(shape.volume),
            "tetrahedron has non-positive rest volume "
                << shape.volume << " mm³ (inverted or flat); reorder its nodes or remove it");
  shape.rest_edges_inv = Dm.inverse();
  BS_VERIFY(shape.rest_edges_inv.allFinite(),
            "tetrahedron of volume " << shape.volume << " mm³ is too flat to invert its edges");
  // N_k(x) = (Dm⁻¹ (x − X0))_{k−1} for k = 1..3, N_0 = 1 − N_1 − N_2 − N_3.
  shape.grad.bottomRows<3>() = shape.rest_edges_inv;
  shape.grad.row(0) = -shape.rest_edges_inv.colwise().sum();
  return shape;
}

Eigen::Matrix<double, 6, 6> isotropic_elasticity(double youngs_modulus, double poisson_ratio) {
  BS_VERIFY(youngs_modulus > 0.0 && std::isfinite(youngs_modulus),
            "Young's modulus must be positive and finite, got " << youngs_modulus << " kPa");
  BS_VERIFY(poisson_ratio > -1.0 && poisson_ratio < 0.5,
            "Poisson ratio must lie in (-1, 0.5), got " << poisson_ratio);
  const double E = youngs_modulus;
  const double nu = poisson_ratio;
  const double lambda = E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
  const double mu = E / (2.0 * (1.0 + nu));
  Eigen::Matrix<double, 6, 6> D = Eigen::Matrix<double, 6, 6>::Zero();
  D.topLeftCorner<3, 3>().setConstant(lambda);
  D.topLeftCorner<3, 3>().diagonal().array() += 2.0 * mu;
  D.bottomRightCorner<3, 3>().diagonal().setConstant(mu);  // engineering shear strain
  return D;
}

Matrix12d linear_tet_stiffness(const TetShape& shape, double youngs_modulus, double poisson_ratio) {
  // Strain-displacement matrix B (6×12), Voigt order xx, yy, zz, xy, yz, zx.
  Eigen::Matrix<double, 6, 12> B = Eigen::Matrix<double, 6, 12>::Zero();
  for (int k = 0; k < 4; ++k) {
    const double a = shape.grad(k, 0);
    const double b = shape.grad(k, 1);
    const double c = shape.grad(k, 2);
    const int j = 3 * k;
    B(0, j) = a;
    B(1, j + 1) = b;
    B(2, j + 2) = c;
    B(3, j) = b;
    B(3, j + 1) = a;
    B(4, j + 1) = c;
    B(4, j + 2) = b;
    B(5, j) = c;
    B(5, j + 2) = a;
  }
  const Eigen::Matrix<double, 6, 6> D = isotropic_elasticity(youngs_modulus, poisson_ratio);
  Matrix12d K = shape.volume * B.transpose() * D * B;
  // Symmetrise exactly: the product above is symmetric up to rounding only.
  return 0.5 * (K + K.transpose());
}

}  // namespace brainshift::core
