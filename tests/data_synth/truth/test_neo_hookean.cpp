#include "random_rotation.hpp"
#include "tolerance.hpp"

#include "data_synth/truth/neo_hookean.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace brainshift::data_synth {
namespace {

/// A random deformation gradient with det F > 0 (up to ±40 % stretches and shears).
Matrix3d random_f(std::mt19937& rng) {
  std::uniform_real_distribution<double> d(-0.4, 0.4);
  Matrix3d F = Matrix3d::Identity();
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) F(i, j) += d(rng);
  if (F.determinant() <= 0.1) F = Matrix3d::Identity() + 0.1 * F;
  return F;
}

TEST(NeoHookean, FromYoungsMatchesShearAndBulkModuli) {
  const NeoHookean m = NeoHookean::from_youngs(1.5, 0.45);
  // μ = E/(2(1+ν)), κ = E/(3(1−2ν)); exact up to rounding.
  EXPECT_TRUE(tests::near(m.mu, 1.5 / 2.9, 0, 4 * tests::eps));
  EXPECT_TRUE(tests::near(m.kappa, 1.5 / 0.3, 0, 4 * tests::eps));
}

TEST(NeoHookean, StressFreeAndZeroEnergyAtRest) {
  const NeoHookean m{0.5, 5.0};
  EXPECT_NEAR(m.energy(Matrix3d::Identity()), 0.0, 1e-15);
  EXPECT_LT(m.first_piola(Matrix3d::Identity()).norm(), 1e-14);
}

TEST(NeoHookean, FirstPiolaIsTheFiniteDifferenceOfTheEnergy) {
  std::mt19937 rng(7);
  const NeoHookean m{0.517, 5.0};
  // Central differences with step h have truncation error O(h² W''') ≈ 1e-12 and rounding
  // error O(eps W / h) ≈ 1e-10 relative to |P| ≈ 1: 1e-7 leaves a wide margin.
  constexpr double h = 1e-6, rel_tol = 1e-7;
  for (int trial = 0; trial < 20; ++trial) {
    const Matrix3d F = random_f(rng);
    SCOPED_TRACE(::testing::Message() << "F =\n" << F);
    Matrix3d fd;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        Matrix3d Fp = F, Fm = F;
        Fp(i, j) += h;
        Fm(i, j) -= h;
        fd(i, j) = (m.energy(Fp) - m.energy(Fm)) / (2 * h);
      }
    const Matrix3d P = m.first_piola(F);
    EXPECT_LT(tests::relative_difference(P, fd), rel_tol) << "P =\n" << P << "\nFD =\n" << fd;
  }
}

TEST(NeoHookean, IsFrameIndifferent) {
  std::mt19937 rng(11);
  const NeoHookean m{0.517, 5.0};
  for (int trial = 0; trial < 10; ++trial) {
    const Matrix3d F = random_f(rng), R = tests::random_rotation(rng);
    // W(RF) = W(F) and P(RF) = R P(F); only rounding differs (≈ 10 eps of |P|).
    EXPECT_TRUE(tests::near(m.energy(R * F), m.energy(F), 1e-13, 1e-12));
    EXPECT_LT(tests::relative_difference(m.first_piola(R * F), R * m.first_piola(F)), 1e-12);
  }
}

TEST(NeoHookean, LinearisesToIsotropicElasticity) {
  const double E = 1.5, nu = 0.45;
  const NeoHookean m = NeoHookean::from_youngs(E, nu);
  const double lame = E * nu / ((1 + nu) * (1 - 2 * nu));
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> d(-1.0, 1.0);
  Matrix3d H;
  for (int i = 0; i < 9; ++i) H(i / 3, i % 3) = d(rng);
  // P(I + εH) = ε (λ tr(ε) I + 2μ sym H) + O(ε²): with ε = 1e-7 the relative O(ε) term is ≈ 1e-6.
  constexpr double e = 1e-7;
  const Matrix3d strain = 0.5 * (H + H.transpose());
  const Matrix3d linear = lame * strain.trace() * Matrix3d::Identity() + 2 * m.mu * strain;
  EXPECT_LT(
      tests::relative_difference(Matrix3d(m.first_piola(Matrix3d::Identity() + e * H) / e), linear),
      1e-5);
}

}  // namespace
}  // namespace brainshift::data_synth
