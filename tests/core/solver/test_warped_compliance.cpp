#include "random_rotation.hpp"
#include "tolerance.hpp"

#include "core/assembly/stiffness_assembly.hpp"
#include "core/error.hpp"
#include "core/solver/nodal_rotations.hpp"
#include "core/solver/warped_compliance.hpp"
#include "data_synth/geometry/structured_mesh.hpp"

#include <Eigen/Cholesky>
#include <gtest/gtest.h>

#include <random>

namespace brainshift::core {
namespace {

using tests::random_rotation;

Eigen::VectorXd random_vector(Eigen::Index n, std::mt19937& rng) {
  std::normal_distribution<double> normal;
  Eigen::VectorXd v(n);
  for (Eigen::Index i = 0; i < n; ++i) v(i) = normal(rng);
  return v;
}

class WarpedComplianceTest : public ::testing::Test {
 protected:
  void SetUp() override {
    std::vector<index_t> fixed;
    for (index_t i = 0; i < mesh.num_nodes(); ++i)
      if (mesh.nodes()(i, 0) < 1e-9) fixed.push_back(i);
    dofs = DofMap(mesh.num_nodes(), fixed);
    Kff = dofs.restrict(assemble_rest_stiffness(model));
    ASSERT_EQ(factor.compute(Kff), FactorStatus::OK) << factor.message();
    for (index_t n = 0; n < mesh.num_nodes(); ++n) rotations.push_back(random_rotation(rng));
  }
  std::mt19937 rng{2024};
  TetMesh mesh = data_synth::make_box_mesh({12, 6, 6}, {4, 2, 2});
  CorotationalModel model{mesh};
  DofMap dofs;
  SparseMatrix Kff;
  CholmodFactor factor;
  std::vector<Matrix3d> rotations;
};

TEST_F(WarpedComplianceTest, IsSymmetric) {
  WarpedCompliance C(factor, dofs);
  C.set_rotations(rotations);
  const Eigen::VectorXd u = random_vector(dofs.num_full(), rng);
  const Eigen::VectorXd v = random_vector(dofs.num_full(), rng);
  const double uCv = u.dot(C.apply(v));
  const double vCu = v.dot(C.apply(u));
  // Symmetric by construction (R K⁻¹ Rᵀ with K⁻¹ applied through L Lᵀ); solve rounding with
  // cond(K_ff) ~ 1e3 stays far below 1e-10 relative.
  EXPECT_TRUE(tests::near(uCv, vCu, 0, 1e-10));
}

TEST_F(WarpedComplianceTest, EqualsTheDenseWarpedInverse) {
  WarpedCompliance C(factor, dofs);
  C.set_rotations(rotations);
  // Dense reference R P (K_ff⁻¹) Pᵀ Rᵀ with P the expansion to full DOFs.
  const Eigen::MatrixXd Kinv = Eigen::LLT<Eigen::MatrixXd>(Eigen::MatrixXd(Kff))
                                   .solve(Eigen::MatrixXd::Identity(Kff.rows(), Kff.cols()));
  Eigen::MatrixXd P = Eigen::MatrixXd::Zero(dofs.num_full(), dofs.num_free());
  for (index_t i = 0; i < dofs.num_free(); ++i) P(dofs.full_index(i), i) = 1.0;
  Eigen::MatrixXd R = Eigen::MatrixXd::Zero(dofs.num_full(), dofs.num_full());
  for (index_t n = 0; n < dofs.num_nodes(); ++n)
    R.block<3, 3>(3 * n, 3 * n) = rotations[static_cast<std::size_t>(n)];
  const Eigen::MatrixXd C_dense = R * P * Kinv * P.transpose() * R.transpose();
  for (int trial = 0; trial < 3; ++trial) {
    const Eigen::VectorXd v = random_vector(dofs.num_full(), rng);
    // Sparse vs dense Cholesky, cond(K_ff) ~ 1e3: agreement ≤ 1e3·ε·cond ≈ 1e-10.
    EXPECT_LE(tests::relative_difference(C.apply(v), Eigen::VectorXd(C_dense * v)), 1e-10);
  }
  // Empty rotations: plain K0⁻¹ (same tolerance reasoning).
  C.set_rotations({});
  const Eigen::VectorXd v = random_vector(dofs.num_full(), rng);
  const Eigen::VectorXd plain = P * Kinv * P.transpose() * v;
  EXPECT_LE(tests::relative_difference(C.apply(v), plain), 1e-10);
}

TEST_F(WarpedComplianceTest, IsZeroOnFixedDofsAndRejectsWrongSizes) {
  WarpedCompliance C(factor, dofs);
  C.set_rotations(rotations);
  const Eigen::VectorXd d = C.apply(random_vector(dofs.num_full(), rng));
  for (index_t n = 0; n < dofs.num_nodes(); ++n)
    if (dofs.is_fixed_node(n)) {
      EXPECT_EQ(d.segment<3>(3 * n).norm(), 0.0);
    }
  EXPECT_THROW(C.set_rotations(std::vector<Matrix3d>(3, Matrix3d::Identity())), Error);
  EXPECT_THROW((void)C.apply(Eigen::VectorXd::Ones(5)), Error);
}

TEST_F(WarpedComplianceTest, NodalRotationsOfAUniformRotationAreThatRotation) {
  const Matrix3d Q = random_rotation(rng);
  const std::vector<Matrix3d> element(static_cast<std::size_t>(mesh.num_tets()), Q);
  for (const Matrix3d& Rn : nodal_rotations(mesh, element)) {
    // Polar factor of (Σ V_e) Q is Q up to SVD rounding.
    EXPECT_LE((Rn - Q).norm(), 1e-13);
  }
}

}  // namespace
}  // namespace brainshift::core
