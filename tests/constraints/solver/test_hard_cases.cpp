// Hard cases of the constraint solver (issue 3 §5): each ends with a finite answer and a
// diagnosis — never NaN, a hang or a crash.
#include "tolerance.hpp"

#include "constraints/fixtures.hpp"
#include "constraints/solver/constrained_step.hpp"

#include <gtest/gtest.h>

namespace brainshift::constraints {
namespace {

struct Beam {
  core::TetMesh mesh = data_synth::make_box_mesh({10, 10, 40}, {2, 2, 8});
  ConstrainedModel model{mesh, tests::nodes_below(mesh, 0), tests::all_nodes(mesh)};
  const MatrixX3d& X() const { return mesh.nodes(); }
  index_t tip() const { return tests::nodes_above(mesh, 40)[4]; }  // top centre
};

StepOptions options() {
  StepOptions o;
  o.pgs.tolerance = 1e-10;
  o.pgs.max_iterations = 2000;
  return o;
}

TEST(HardCases, SamePointConstrainedTwiceConverges) {
  Beam b;
  const Vector3d target = b.X().row(b.tip()).transpose() + Vector3d(2, 0, 0);
  ConstraintRows rows;
  rows.add_bilateral_point(tests::node_stencil(b.tip()), b.X(), target, ConstraintSet::LANDMARK);
  rows.add_bilateral_point(tests::node_stencil(b.tip()), b.X(), target, ConstraintSet::LANDMARK);
  const StepResult s = b.model.step(b.X(), rows, options());
  ASSERT_TRUE(s.x.allFinite());
  EXPECT_EQ(s.pgs.stop, PgsStop::CONVERGED) << s.pgs.message;  // W singular but consistent
  // One linear-equivalent step from rest: the point reaches its target to the PGS tolerance.
  EXPECT_LT((s.x.row(b.tip()).transpose() - target).norm(), 1e-8);
}

TEST(HardCases, OnePointPulledTwoOppositeWaysStallsWithADiagnosis) {
  Beam b;
  const Vector3d p = b.X().row(b.tip()).transpose();
  ConstraintRows rows;
  rows.add_bilateral_point(tests::node_stencil(b.tip()), b.X(), p + Vector3d(5, 0, 0),
                           ConstraintSet::LANDMARK);
  rows.add_bilateral_point(tests::node_stencil(b.tip()), b.X(), p - Vector3d(5, 0, 0),
                           ConstraintSet::LANDMARK);
  const StepResult s = b.model.step(b.X(), rows, options());
  ASSERT_TRUE(s.x.allFinite());
  ASSERT_TRUE(s.lambda.allFinite());
  EXPECT_EQ(s.pgs.stop, PgsStop::STALLED);
  EXPECT_NE(s.diagnosis.find("inconsistent"), std::string::npos) << s.diagnosis;
  // The point ends on one of the two targets or between them, never beyond.
  EXPECT_LE(std::abs(s.x(b.tip(), 0) - p.x()), 5.0 + 1e-6);
}

TEST(HardCases, MoreRowsThanFreeDofsAndRankDeficientW) {
  // One tetrahedron with three fixed nodes: 3 free DOFs, 9 consistent rows + a duplicate line.
  MatrixX3d X(4, 3);
  X << 0, 0, 0, 10, 0, 0, 0, 10, 0, 0, 0, 10;
  MatrixX4i T(1, 4);
  T << 0, 1, 2, 3;
  const core::TetMesh mesh(X, T);
  ConstrainedModel model(mesh, {0, 1, 2}, {3});
  const Vector3d target(1, 2, 11);
  ConstraintRows rows;
  for (int k = 0; k < 3; ++k)
    rows.add_bilateral_point(tests::node_stencil(3), X, target, ConstraintSet::LANDMARK);
  rows.add_sliding_line(tests::node_stencil(3), X, target, Vector3d::UnitZ(),
                        ConstraintSet::VESSELS);
  ASSERT_GT(rows.size(), 3 * 1);
  const StepResult s = model.step(X, rows, options());
  ASSERT_TRUE(s.x.allFinite());
  EXPECT_EQ(s.pgs.stop, PgsStop::CONVERGED) << s.pgs.message;
  EXPECT_LT((s.x.row(3).transpose() - target).norm(), 1e-8);  // small linear step from rest
}

TEST(HardCases, AViolationOfOneMetreGivesAFiniteAnswerAndAWarning) {
  Beam b;
  ConstraintRows rows;
  rows.add_bilateral_point(tests::node_stencil(b.tip()), b.X(),
                           b.X().row(b.tip()).transpose() + Vector3d(1000, 0, 0),
                           ConstraintSet::VESSELS);
  MatrixX3d x = b.X();
  Eigen::VectorXd lambda;
  StepResult s;
  for (int k = 0; k < 5; ++k) {  // keep stepping through the distorted states
    ConstraintRows r;
    r.add_bilateral_point(tests::node_stencil(b.tip()), x,
                          b.X().row(b.tip()).transpose() + Vector3d(1000, 0, 0),
                          ConstraintSet::VESSELS);
    s = b.model.step(x, r, options(), lambda);
    ASSERT_TRUE(s.x.allFinite()) << "step " << k;
    ASSERT_TRUE(s.lambda.allFinite()) << "step " << k;
    x = s.x;
    lambda = s.lambda;
  }
  const StepResult first = b.model.step(b.X(), rows, options());
  EXPECT_NE(first.diagnosis.find("plausible"), std::string::npos) << first.diagnosis;
}

TEST(HardCases, RowsOnFixedNodesAreIgnoredWithADiagnosis) {
  Beam b;
  const index_t fixed = tests::nodes_below(b.mesh, 0)[0];
  ConstraintRows rows;
  rows.add_bilateral_point(tests::node_stencil(fixed), b.X(),
                           b.X().row(fixed).transpose() + Vector3d(1, 0, 0), ConstraintSet::FIXED);
  const Vector3d target = b.X().row(b.tip()).transpose() + Vector3d(0, 1, 0);
  rows.add_bilateral_point(tests::node_stencil(b.tip()), b.X(), target, ConstraintSet::LANDMARK);
  const StepResult s = b.model.step(b.X(), rows, options());
  ASSERT_TRUE(s.x.allFinite());
  EXPECT_EQ(s.pgs.ignored_rows, 3);
  EXPECT_NE(s.diagnosis.find("fixed nodes"), std::string::npos) << s.diagnosis;
  EXPECT_EQ(s.x.row(fixed), b.X().row(fixed));                      // fixed nodes never move
  EXPECT_LT((s.x.row(b.tip()).transpose() - target).norm(), 1e-8);  // the rest is still solved
}

TEST(HardCases, ASliverUnderAConstraintStaysFinite) {
  // A regular tetrahedron plus a sliver on its top face whose apex is 1e-4 mm above that face.
  MatrixX3d X(5, 3);
  X << 0, 0, 0, 10, 0, 0, 0, 10, 0, 0, 0, 10, 3.3333, 3.3333, 3.3334 + 1e-4;
  MatrixX4i T(2, 4);
  T << 0, 1, 2, 3, 1, 2, 3, 4;
  core::TetMesh probe(X, T);
  if (probe.signed_volume(1) < 0) T.row(1) << 1, 3, 2, 4;
  const core::TetMesh mesh(X, T);
  ASSERT_NO_THROW(core::validate(mesh));
  EXPECT_EQ(core::quality_report(mesh).sliver_count, 1);
  ConstrainedModel model(mesh, {0, 1, 2}, {3, 4});
  ConstraintRows rows;
  rows.add_bilateral_point(tests::node_stencil(4), X, X.row(4).transpose() + Vector3d(0, 0, 2),
                           ConstraintSet::LANDMARK);
  const StepResult s = model.step(X, rows, options());
  EXPECT_TRUE(s.x.allFinite());
  EXPECT_TRUE(s.lambda.allFinite());
  EXPECT_NE(s.pgs.stop, PgsStop::NO_ROWS);
}

}  // namespace
}  // namespace brainshift::constraints
