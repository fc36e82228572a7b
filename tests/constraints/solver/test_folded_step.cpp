// The compliance operator's pieces: several right-hand sides at once and the correction read
// from the dense block, against one apply() per column.
#include "random_rotation.hpp"
#include "tolerance.hpp"

#include "constraints/fixtures.hpp"
#include "constraints/solver/compliance_operator.hpp"
#include "constraints/solver/constrained_step.hpp"

#include <gtest/gtest.h>

#include <random>

namespace brainshift::constraints {
namespace {

std::vector<Matrix3d> folded_step_rotations(index_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::vector<Matrix3d> R(static_cast<std::size_t>(n));
  for (auto& r : R) r = tests::random_rotation(rng);
  return R;
}

/// Sliding-line rows on nodes of the top half (z ≥ 20 mm) of the 20 × 20 × 40 mm box.
ConstraintRows top_rows(const core::TetMesh& mesh, const MatrixX3d& x, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  const std::vector<index_t> top = tests::nodes_above(mesh, 20);
  ConstraintRows rows;
  for (std::size_t k = 0; k < top.size(); k += 3) {
    Stencil s;
    s.add(top[k], 0.6);
    s.add(top[(k + 1) % top.size()], 0.4);
    const Vector3d target = s.position(x) + Vector3d(u(rng), u(rng), 2.0 + u(rng));
    rows.add_sliding_line(s, x, target, Vector3d(u(rng), u(rng), 1), ConstraintSet::VESSELS);
  }
  return rows;
}

TEST(ComplianceOperator, SeveralColumnsAtOnceAndTheBlockCorrectionMatchApply) {
  const auto mesh = data_synth::make_box_mesh({20, 20, 40}, {3, 3, 6});
  const std::vector<index_t> block = tests::nodes_above(mesh, 20);
  // The three paths in double (apply's float solve on large factors has its own test,
  // ApplySolvesInSinglePrecisionAboveTheCacheSizeWithFloatsBackwardError): here they must agree
  // to double rounding, whatever the size threshold.
  ComplianceOptions in_double;
  in_double.single_precision_solves = false;
  ConstrainedModel model(mesh, tests::nodes_below(mesh, 0), block, in_double);
  const ComplianceOperator& C = model.compliance();
  ASSERT_EQ(C.strategy(), ComplianceStrategy::DENSE_BLOCK);
  ASSERT_FALSE(C.single_precision());
  const std::vector<Matrix3d> R = folded_step_rotations(mesh.num_nodes(), 3);
  std::mt19937 rng(4);
  std::normal_distribution<double> g;
  const index_t n3 = 3 * mesh.num_nodes();
  Eigen::MatrixXd V(n3, 2);
  for (Eigen::Index i = 0; i < V.size(); ++i) V.data()[i] = g(rng);
  const Eigen::MatrixXd U = C.apply_columns(V, R);
  for (Eigen::Index j = 0; j < 2; ++j)  // the same solve, one column or two: rounding only
    EXPECT_LT(tests::relative_difference(U.col(j), C.apply(Eigen::VectorXd(V.col(j)), R)), 1e-12)
        << "column " << j;
  // A force on block nodes only: the block gives R K0⁻¹ Rᵀ v on the block nodes, zero elsewhere.
  Eigen::VectorXd v = Eigen::VectorXd::Zero(n3);
  for (std::size_t k = 0; k < block.size(); k += 2) v.segment<3>(3 * block[k]) << g(rng), g(rng), 1;
  const Eigen::VectorXd full = C.apply(v, R);
  const Eigen::VectorXd from_block = C.apply_block(v, R);
  std::vector<bool> in_block(static_cast<std::size_t>(mesh.num_nodes()), false);
  for (index_t b : block) in_block[static_cast<std::size_t>(b)] = true;
  double on = 0, off = 0;
  for (index_t n = 0; n < mesh.num_nodes(); ++n) {
    if (in_block[static_cast<std::size_t>(n)])
      on = std::max(on, (from_block.segment<3>(3 * n) - full.segment<3>(3 * n)).norm());
    else
      off = std::max(off, from_block.segment<3>(3 * n).norm());
  }
  // The block holds K0⁻¹ from the same factor's solves: agreement to rounding (≈ 1e-15 relative).
  EXPECT_LT(on, 1e-10 * full.norm());
  EXPECT_EQ(off, 0.0);  // nothing outside the block nodes
  // covers(): rows on the block are covered, a row on a node below the block is not.
  const MatrixX3d x = mesh.nodes();
  EXPECT_TRUE(C.covers(top_rows(mesh, x, 5).jacobian(mesh.num_nodes())));
  index_t below = 0;  // a free node under the block
  while (!(mesh.nodes()(below, 2) > 1 && mesh.nodes()(below, 2) < 19)) ++below;
  ConstraintRows low;
  low.add_bilateral_point(tests::node_stencil(below), x, Vector3d::Zero(), ConstraintSet::LANDMARK);
  EXPECT_FALSE(C.covers(low.jacobian(mesh.num_nodes())));
}

}  // namespace
}  // namespace brainshift::constraints
