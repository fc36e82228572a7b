#include "random_rotation.hpp"
#include "tolerance.hpp"

#include "core/error.hpp"
#include "core/fem/rotation.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <string>

namespace brainshift::core {
namespace {

using tests::random_rotation;

/// Orthonormality and det = +1 of a computed rotation: both are products of a few orthogonal
/// SVD factors, accurate to a few ulps; 1e-14 leaves a factor ~50 of margin.
void expect_proper_rotation(const Matrix3d& R) {
  ASSERT_TRUE(R.allFinite()) << R;
  EXPECT_LE((R.transpose() * R - Matrix3d::Identity()).norm(), 1e-14) << R;
  EXPECT_TRUE(tests::near(R.determinant(), 1.0, 1e-14, 0)) << R;
}

TEST(Rotation, PolarRotationOfRotatedStretchIsTheRotation) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> stretch(0.5, 2.0);
  for (int trial = 0; trial < 20; ++trial) {
    SCOPED_TRACE("trial " + std::to_string(trial));
    const Matrix3d Q = random_rotation(rng);
    const Matrix3d V = random_rotation(rng);
    const Matrix3d S = V * Vector3d(stretch(rng), stretch(rng), stretch(rng)).asDiagonal() *
                       V.transpose();  // SPD, condition ≤ 4
    bool inverted = true;
    const Matrix3d R = rotation_from_deformation_gradient(Q * S, &inverted);
    EXPECT_FALSE(inverted);
    // SVD backward error ~ε·cond(S) ≤ 4ε per entry; 1e-13 is generous for 3×3.
    EXPECT_LE((R - Q).norm(), 1e-13);
    expect_proper_rotation(R);
  }
}

TEST(Rotation, PolarFactorOfIllConditionedStretchesIsExact) {
  // Stretches with condition up to 1e3 (far beyond tissue strains) take the Newton path or the
  // SVD; either way R is a proper rotation and S = Rᵀ F is the symmetric positive definite polar
  // factor (an independent check that does not need the answer).
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> log_stretch(-1.5, 1.5);
  for (int trial = 0; trial < 200; ++trial) {
    SCOPED_TRACE("trial " + std::to_string(trial));
    const Matrix3d Q = random_rotation(rng);
    const Matrix3d V = random_rotation(rng);
    const Vector3d sigma(std::pow(10.0, log_stretch(rng)), std::pow(10.0, log_stretch(rng)),
                         std::pow(10.0, log_stretch(rng)));
    const Matrix3d F = Q * V * sigma.asDiagonal() * V.transpose();
    const Matrix3d R = rotation_from_deformation_gradient(F);
    expect_proper_rotation(R);
    const Matrix3d S = R.transpose() * F;
    EXPECT_LE((S - S.transpose()).norm(), 1e-12 * F.norm());
    EXPECT_GT(
        Eigen::SelfAdjointEigenSolver<Matrix3d>(0.5 * (S + S.transpose())).eigenvalues().minCoeff(),
        0.0);
    EXPECT_LE((R - Q).norm(), 1e-11);  // the rotation of Q·(SPD) is Q; error ≈ ε·cond
  }
}

struct DegenerateCase {
  std::string name;
  Matrix3d F;
  bool inverted;
};

class RotationOfDegenerateF : public ::testing::TestWithParam<DegenerateCase> {};

TEST_P(RotationOfDegenerateF, IsAProperFiniteRotation) {
  const DegenerateCase& c = GetParam();
  SCOPED_TRACE(c.name);
  bool inverted = !c.inverted;
  const Matrix3d R = rotation_from_deformation_gradient(c.F, &inverted);
  EXPECT_EQ(inverted, c.inverted);
  expect_proper_rotation(R);
}

std::vector<DegenerateCase> degenerate_cases() {
  Matrix3d reflection = Matrix3d::Identity();
  reflection(2, 2) = -1.0;
  Matrix3d rank1 = Vector3d(1, 2, 3) * Vector3d(-1, 0.5, 2).transpose();
  Matrix3d rank2 = Matrix3d::Identity();
  rank2(1, 1) = 0.0;
  Matrix3d inverted_sheared;
  inverted_sheared << 0.9, 0.3, 0.0, 0.1, 1.1, 0.2, 0.0, 0.0, -0.05;
  return {
      {"zero F", Matrix3d::Zero(), true},
      {"reflection", reflection, true},
      {"minus identity", -Matrix3d::Identity(), true},
      {"rank 1", rank1, true},
      {"rank 2", rank2, true},
      {"slightly inverted shear", inverted_sheared, true},
      {"tiny 1e-150", 1e-150 * Matrix3d::Identity(), false},
      {"huge 1e150", 1e150 * Matrix3d::Identity(), false},
  };
}

INSTANTIATE_TEST_SUITE_P(Rotation, RotationOfDegenerateF, ::testing::ValuesIn(degenerate_cases()),
                         [](const auto& param_info) {
                           std::string n = param_info.param.name;
                           for (char& ch : n)
                             if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
                           return n;
                         });

TEST(Rotation, InvertedElementIsPushedBackNotReflected) {
  // F = diag(1, 1, −0.1): the element is flattened through its z-face. The SVD fix gives a
  // rotation, not the reflection diag(1, 1, −1); Rᵀ F then has negative entry (the element
  // wants to uninvert).
  Matrix3d F = Matrix3d::Identity();
  F(2, 2) = -0.1;
  bool inverted = false;
  const Matrix3d R = rotation_from_deformation_gradient(F, &inverted);
  EXPECT_TRUE(inverted);
  expect_proper_rotation(R);
  EXPECT_LT((R.transpose() * F).trace(), 3.0);  // Rᵀ F is not the identity-like stretch
}

TEST(Rotation, NearestRotationOfARotationIsItselfAndOfAnAverageIsOrthonormal) {
  std::mt19937 rng(11);
  const Matrix3d Q = random_rotation(rng);
  // Exact input: only SVD rounding.
  EXPECT_LE((nearest_rotation(Q) - Q).norm(), 1e-14);
  expect_proper_rotation(nearest_rotation(Q + 0.3 * random_rotation(rng)));
  expect_proper_rotation(nearest_rotation(Matrix3d::Zero()));
}

TEST(Rotation, NonFiniteInputThrows) {
  Matrix3d F = Matrix3d::Identity();
  F(1, 2) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW((void)rotation_from_deformation_gradient(F), Error);
  EXPECT_THROW((void)nearest_rotation(F), Error);
}

}  // namespace
}  // namespace brainshift::core
