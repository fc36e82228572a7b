#include "tolerance.hpp"

#include "constraints/rows/constraint_rows.hpp"
#include "core/error.hpp"

#include <gtest/gtest.h>

namespace brainshift::constraints {
namespace {

MatrixX3d three_nodes() {
  MatrixX3d x(3, 3);
  x << 0, 0, 0, 10, 0, 0, 0, 10, 0;
  return x;
}

TEST(ConstraintRows, BilateralPointHasThreeRowsWithTheOffsetAsViolation) {
  const MatrixX3d x = three_nodes();
  Stencil s;
  s.add(1, 1.0);
  ConstraintRows rows;
  rows.add_bilateral_point(s, x, Vector3d(11, 2, -3), ConstraintSet::LANDMARK);
  ASSERT_EQ(rows.size(), 3);
  // δ = p − target, exactly representable values.
  EXPECT_EQ(rows.violations(), Eigen::Vector3d(-1, -2, 3));
  const SparseMatrix H = rows.jacobian(3);
  EXPECT_EQ(H.rows(), 3);
  EXPECT_EQ(H.cols(), 9);
  EXPECT_EQ(Eigen::MatrixXd(H).block(0, 3, 3, 3), Eigen::Matrix3d::Identity());
}

TEST(ConstraintRows, SlidingLineRowsAreNormalToTheTangentAndFreeAlongIt) {
  const MatrixX3d x = three_nodes();
  Stencil s = Stencil::interpolate(
      [] {
        Stencil a;
        a.add(0, 1.0);
        return a;
      }(),
      [] {
        Stencil b;
        b.add(1, 1.0);
        return b;
      }(),
      0.25);
  ConstraintRows rows;
  const Vector3d tangent(1, 1, 0);
  rows.add_sliding_line(s, x, Vector3d(0, 3, 4), tangent, ConstraintSet::VESSELS);
  ASSERT_EQ(rows.size(), 2);
  for (index_t i = 0; i < 2; ++i)
    EXPECT_TRUE(tests::near(rows[i].direction.dot(tangent), 0, 1e-15, 0));
  // Moving the point along the tangent does not change g; moving it normally does.
  MatrixX3d y = x;
  y.row(0) += 4 * tangent.transpose();
  y.row(1) += 4 * tangent.transpose();
  EXPECT_LT((rows.values(y) - rows.violations()).cwiseAbs().maxCoeff(), 1e-12);
  // The point (2.5, 0, 0) is at distance |(2.5,0,0)-(0,3,4)| minus its tangent part from the line.
  const Vector3d d = Vector3d(2.5, 0, 0) - Vector3d(0, 3, 4);
  const double normal_distance = (d - d.dot(tangent.normalized()) * tangent.normalized()).norm();
  EXPECT_TRUE(tests::near(rows.violations().norm(), normal_distance, 1e-12, 0));
}

TEST(ConstraintRows, UnilateralValueIsSignedAlongTheNormal) {
  const MatrixX3d x = three_nodes();
  ConstraintRows rows;
  Stencil s;
  s.add(2, 1.0);
  rows.add_unilateral_plane(s, x, Vector3d(0, 12, 0), Vector3d(0, -1, 0), ConstraintSet::FOOTPRINT);
  EXPECT_EQ(rows[0].law, ConstraintLaw::UNILATERAL);
  EXPECT_EQ(rows.violations()[0], 2.0);  // 2 mm on the allowed side
  EXPECT_EQ(rows.count_by_set()[static_cast<int>(ConstraintSet::FOOTPRINT)], 1);
}

TEST(ConstraintRows, BadInputIsRejectedWithAMessage) {
  const MatrixX3d x = three_nodes();
  ConstraintRows rows;
  Stencil s;
  s.add(7, 1.0);
  EXPECT_THROW(rows.add_bilateral_point(s, x, Vector3d::Zero(), ConstraintSet::LANDMARK), Error);
  Stencil ok;
  ok.add(0, 1.0);
  EXPECT_THROW(
      rows.add_sliding_line(ok, x, Vector3d::Zero(), Vector3d::Zero(), ConstraintSet::VESSELS),
      Error);
  EXPECT_THROW(rows.add_bilateral_point(ok, x, Vector3d(NAN, 0, 0), ConstraintSet::LANDMARK),
               Error);
}

}  // namespace
}  // namespace brainshift::constraints
