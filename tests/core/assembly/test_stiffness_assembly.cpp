#include "tolerance.hpp"

#include "core/assembly/dof_map.hpp"
#include "core/assembly/stiffness_assembly.hpp"
#include "core/error.hpp"
#include "core/solver/cholmod_factor.hpp"
#include "data_synth/geometry/structured_mesh.hpp"

#include <Eigen/Cholesky>
#include <gtest/gtest.h>

#include <random>
#include <string>

namespace brainshift::core {
namespace {

/// The six rigid modes of the nodes X (#N×3) as 3N×6 columns (3 translations, 3 rotations).
Eigen::MatrixXd rigid_modes(const MatrixX3d& X) {
  Eigen::MatrixXd modes = Eigen::MatrixXd::Zero(3 * X.rows(), 6);
  for (Eigen::Index i = 0; i < X.rows(); ++i) {
    modes.block<3, 3>(3 * i, 0).setIdentity();
    for (int a = 0; a < 3; ++a) {
      modes.block<3, 1>(3 * i, 3 + a) = Vector3d::Unit(a).cross(X.row(i).transpose());
    }
  }
  return modes;
}

std::vector<index_t> nodes_with_z(const TetMesh& mesh, double z) {
  std::vector<index_t> out;
  for (index_t i = 0; i < mesh.num_nodes(); ++i) {
    if (std::abs(mesh.nodes()(i, 2) - z) < 1e-9) out.push_back(i);
  }
  return out;
}

class StiffnessAssemblyTest : public ::testing::Test {
 protected:
  TetMesh mesh = data_synth::make_box_mesh({10, 12, 14}, {3, 3, 4}, {2, -3, 1});
  CorotationalModel model{mesh};
  SparseMatrix K0 = assemble_rest_stiffness(model);
};

TEST_F(StiffnessAssemblyTest, RestStiffnessIsSymmetricWithTheRigidModesInItsNullSpace) {
  ASSERT_EQ(K0.rows(), 3 * mesh.num_nodes());
  // Each element block is symmetrised exactly and summed in the same order for (i,j), (j,i).
  EXPECT_EQ(SparseMatrix(K0 - SparseMatrix(K0.transpose())).norm(), 0.0);
  const Eigen::MatrixXd modes = rigid_modes(mesh.nodes());
  for (int m = 0; m < 6; ++m) {
    SCOPED_TRACE("rigid mode " + std::to_string(m));
    // Rounding in K_e·r is ~ε·‖K_e‖·‖r‖ per element (cancellation of O(1) terms): 1e-13.
    EXPECT_LE((K0 * modes.col(m)).norm(), 1e-13 * K0.norm() * modes.col(m).norm());
  }
}

TEST_F(StiffnessAssemblyTest, DirichletEliminationMakesKffPositiveDefinite) {
  const DofMap dofs(mesh.num_nodes(), nodes_with_z(mesh, 1.0));
  const SparseMatrix Kff = dofs.restrict(K0);
  ASSERT_EQ(Kff.rows(), dofs.num_free());
  CholmodFactor factor;
  ASSERT_EQ(factor.compute(Kff), FactorStatus::OK) << factor.message();
  const Eigen::MatrixXd dense(Kff);
  const Eigen::LLT<Eigen::MatrixXd> llt(dense);
  ASSERT_EQ(llt.info(), Eigen::Success);
  std::mt19937 rng(1);
  std::normal_distribution<double> normal;
  Eigen::VectorXd b(Kff.rows());
  for (Eigen::Index i = 0; i < b.size(); ++i) b(i) = normal(rng);
  // Both backward-stable Cholesky solves of a matrix with cond ~1e4 (soft box, 4 layers):
  // forward error ≲ n·ε·cond ≈ 1e-9; they agree much better in practice.
  EXPECT_LE(tests::relative_difference(factor.solve(b), Eigen::VectorXd(llt.solve(b))), 1e-9);
}

TEST_F(StiffnessAssemblyTest, RotatedStiffnessIsTheConjugatedRestStiffness) {
  const Matrix3d Q = Eigen::AngleAxisd(1.1, Vector3d(1, -2, 0.5).normalized()).toRotationMatrix();
  const std::vector<Matrix3d> rotations(static_cast<std::size_t>(mesh.num_tets()), Q);
  const SparseMatrix KR = assemble_rotated_stiffness(model, rotations);
  std::vector<Triplet> q;
  for (index_t n = 0; n < mesh.num_nodes(); ++n)
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) q.emplace_back(3 * n + i, 3 * n + j, Q(i, j));
  SparseMatrix Qhat(K0.rows(), K0.cols());
  Qhat.setFromTriplets(q.begin(), q.end());
  const SparseMatrix expected = Qhat * K0 * SparseMatrix(Qhat.transpose());
  // Two orders of the same 3×3 products: rounding 1e-14 relative to ‖K0‖.
  EXPECT_LE(SparseMatrix(KR - expected).norm(), 1e-14 * K0.norm());
  EXPECT_THROW((void)assemble_rotated_stiffness(model, {}), Error);
}

TEST(DofMap, RestrictAndExpandRoundTripAndRejectBadNodes) {
  const DofMap dofs(4, {2, 0, 2});
  EXPECT_EQ(dofs.num_free(), 6);
  EXPECT_TRUE(dofs.is_fixed_node(0));
  EXPECT_FALSE(dofs.is_fixed_node(1));
  EXPECT_EQ(dofs.free_index(3), 0);
  EXPECT_EQ(dofs.free_index(0), -1);
  EXPECT_EQ(dofs.full_index(5), 11);
  Eigen::VectorXd full = Eigen::VectorXd::LinSpaced(12, 1, 12);
  const Eigen::VectorXd free = dofs.restrict(full);
  EXPECT_EQ(free, (Eigen::VectorXd(6) << 4, 5, 6, 10, 11, 12).finished());
  const Eigen::VectorXd back = dofs.expand(free);
  EXPECT_EQ(back, (Eigen::VectorXd(12) << 0, 0, 0, 4, 5, 6, 0, 0, 0, 10, 11, 12).finished());
  EXPECT_THROW(DofMap(4, {4}), Error);
  EXPECT_THROW(DofMap(4, {-1}), Error);
  EXPECT_THROW((void)dofs.restrict(Eigen::VectorXd(5)), Error);
}

}  // namespace
}  // namespace brainshift::core
