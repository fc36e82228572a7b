#include "tolerance.hpp"

#include "core/error.hpp"
#include "core/fem/linear_tet.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <gtest/gtest.h>

#include <string>

namespace brainshift::core {
namespace {

using Nodes = Eigen::Matrix<double, 4, 3>;

Nodes irregular_tet() {
  Nodes X;
  X << 0.3, -0.2, 0.1,  //
      4.1, 0.5, -0.3,   //
      0.7, 3.2, 0.4,    //
      0.2, 0.9, 2.7;
  return X;
}

/// The six rigid modes (3 translations, 3 infinitesimal rotations) of 4 nodes, as 12×6 columns.
Eigen::Matrix<double, 12, 6> rigid_modes(const Nodes& X) {
  Eigen::Matrix<double, 12, 6> modes = Eigen::Matrix<double, 12, 6>::Zero();
  for (int k = 0; k < 4; ++k) {
    modes.block<3, 3>(3 * k, 0).setIdentity();
    const Vector3d p = X.row(k).transpose();
    for (int a = 0; a < 3; ++a) modes.block<3, 1>(3 * k, 3 + a) = Vector3d::Unit(a).cross(p);
  }
  return modes;
}

TEST(LinearTet, ShapeGradientsReproduceLinearFields) {
  const Nodes X = irregular_tet();
  const TetShape s = tet_shape(X);
  const Vector3d a(0.7, -1.3, 2.1);
  const Eigen::Vector4d values = X * a;  // φ(x) = a·x at the nodes
  // Constant-strain element: gradients of a linear field are exact up to rounding of Dm⁻¹.
  EXPECT_LE(tests::relative_difference(Vector3d(s.grad.transpose() * values), a), 1e-13);
  // The gradients of a partition of unity sum to zero (rounding of the sum of three entries).
  EXPECT_LE(s.grad.colwise().sum().norm(), 1e-14 * s.grad.norm());
  // V = det(Dm)/6 for this tetrahedron, computed independently by the triple product.
  const Vector3d e1 = (X.row(1) - X.row(0)).transpose();
  const Vector3d e2 = (X.row(2) - X.row(0)).transpose();
  const Vector3d e3 = (X.row(3) - X.row(0)).transpose();
  EXPECT_TRUE(tests::near(s.volume, e1.dot(e2.cross(e3)) / 6.0, 0, 8 * tests::eps));
}

TEST(LinearTet, ElasticityMatrixGivesUniaxialCompliance) {
  const double E = 3.0;
  const double nu = 0.45;
  const Eigen::Matrix<double, 6, 6> D = isotropic_elasticity(E, nu);
  Eigen::Matrix<double, 6, 1> stress = Eigen::Matrix<double, 6, 1>::Zero();
  stress(0) = 1.0;
  const Eigen::Matrix<double, 6, 1> strain = D.lu().solve(stress);
  // Uniaxial stress σ_xx = 1: ε_xx = 1/E, ε_yy = ε_zz = −ν/E, no shear. D has condition number
  // ≈ 1/(1−2ν) = 10 here, so a few hundred ε covers the LU solve.
  EXPECT_TRUE(tests::near(strain(0), 1.0 / E, 0, 1e-13));
  EXPECT_TRUE(tests::near(strain(1), -nu / E, 0, 1e-13));
  EXPECT_TRUE(tests::near(strain(2), -nu / E, 0, 1e-13));
  EXPECT_LE(strain.tail<3>().norm(), 1e-14);
  EXPECT_THROW((void)isotropic_elasticity(-1.0, 0.3), Error);
  EXPECT_THROW((void)isotropic_elasticity(1.0, 0.5), Error);
}

TEST(LinearTet, StiffnessIsSymmetricPsdWithTheSixRigidModesInItsNullSpace) {
  const Nodes X = irregular_tet();
  const Matrix12d K = linear_tet_stiffness(tet_shape(X), 1.5, 0.45);
  EXPECT_EQ((K - K.transpose()).norm(), 0.0);  // symmetrised explicitly
  const Eigen::Matrix<double, 12, 6> modes = rigid_modes(X);
  for (int m = 0; m < 6; ++m) {
    SCOPED_TRACE("rigid mode " + std::to_string(m));
    // Cancellation in B·r leaves rounding of order ε·|∇N|·|X|: 1e-13 relative is ~500 ε.
    EXPECT_LE((K * modes.col(m)).norm(), 1e-13 * K.norm() * modes.col(m).norm());
  }
  const Eigen::SelfAdjointEigenSolver<Matrix12d> eig(K);
  const double largest = eig.eigenvalues()(11);
  for (int i = 0; i < 6; ++i) EXPECT_LE(std::abs(eig.eigenvalues()(i)), 1e-12 * largest);
  // The six deformation modes are stiff: smallest non-zero eigenvalue well above rounding.
  EXPECT_GT(eig.eigenvalues()(6), 1e-3 * largest);
}

TEST(LinearTet, StrainEnergyOfAnAffineFieldIsVolumeTimesEnergyDensity) {
  const Nodes X = irregular_tet();
  const TetShape s = tet_shape(X);
  const double E = 2.0;
  const double nu = 0.3;
  Matrix3d G;  // displacement gradient
  G << 1e-2, 2e-3, -1e-3, 4e-3, -5e-3, 3e-3, 0.0, 1e-3, 7e-3;
  Vector12d u;
  for (int k = 0; k < 4; ++k) u.segment<3>(3 * k) = G * X.row(k).transpose();
  const Matrix3d eps = 0.5 * (G + G.transpose());
  Eigen::Matrix<double, 6, 1> voigt;
  voigt << eps(0, 0), eps(1, 1), eps(2, 2), 2 * eps(0, 1), 2 * eps(1, 2), 2 * eps(2, 0);
  const double expected = 0.5 * s.volume * voigt.dot(isotropic_elasticity(E, nu) * voigt);
  const double energy = 0.5 * u.dot(linear_tet_stiffness(s, E, nu) * u);
  // Same quantity by two orderings of a handful of products: 1e-12 relative.
  EXPECT_TRUE(tests::near(energy, expected, 0, 1e-12));
}

TEST(LinearTet, InvertedOrFlatTetrahedronThrowsNamingTheVolume) {
  Nodes X = irregular_tet();
  X.row(1).swap(X.row(2));  // inverted
  try {
    (void)tet_shape(X);
    FAIL() << "inverted tetrahedron accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("volume -"), std::string::npos) << e.what();
  }
  Nodes flat = irregular_tet();
  flat(3, 2) = 0.1;
  flat.col(2).setConstant(0.1);  // all four nodes in the plane z = 0.1
  try {
    (void)tet_shape(flat);
    FAIL() << "flat tetrahedron accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("rest volume"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace brainshift::core
