#include "tolerance.hpp"

#include "core/error.hpp"
#include "core/mapping/barycentric_mapping.hpp"
#include "data_synth/geometry/structured_mesh.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <string>

namespace brainshift::core {
namespace {

/// `count` random points inside the ellipsoid with semi-axes `a` shrunk by 10 % (well inside the
/// polyhedral mesh of it).
MatrixX3d random_inside_points(const Vector3d& a, int count, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  MatrixX3d P(count, 3);
  for (int i = 0; i < count;) {
    const Vector3d d(u(rng), u(rng), u(rng));
    if (d.norm() > 0.9) continue;
    P.row(i++) = a.cwiseProduct(d).transpose();
  }
  return P;
}

class BarycentricMappingTest : public ::testing::Test {
 protected:
  const Vector3d semi_axes{60, 70, 50};
  const TetMesh mesh = data_synth::make_ellipsoid_mesh(semi_axes, 8);
  const MatrixX3d points = random_inside_points(semi_axes, 500, 7);
};

TEST_F(BarycentricMappingTest, ReproducesInsidePointsAtRest) {
  const BarycentricMapping J(mesh, points);
  EXPECT_EQ(J.num_points(), 500);
  EXPECT_EQ(J.num_nodes(), mesh.num_nodes());
  EXPECT_EQ(J.matrix().rows(), 500);
  EXPECT_EQ(J.matrix().cols(), mesh.num_nodes());
  // Coordinates up to 70 mm: rounding of a 4-term weighted sum is ~1e-14 mm.
  EXPECT_LT((J.apply(mesh.nodes()) - points).cwiseAbs().maxCoeff(), 1e-12);
  for (index_t i = 0; i < J.num_points(); ++i) {
    EXPECT_EQ(J.outside_distance()[static_cast<std::size_t>(i)], 0.0);
    EXPECT_GE(J.weights().row(i).minCoeff(), 0.0);
  }
}

TEST_F(BarycentricMappingTest, RowsSumToOneWithAtMostFourEntries) {
  const BarycentricMapping J(mesh, points);
  const Eigen::VectorXd row_sums = J.matrix() * Eigen::VectorXd::Ones(J.num_nodes());
  // Four non-negative weights normalised to 1: a few ulps.
  EXPECT_LT((row_sums.array() - 1.0).abs().maxCoeff(), 4 * tests::eps);
  const SparseMatrix Jt = J.matrix().transpose();  // column-major: rows of J are columns
  for (index_t i = 0; i < Jt.outerSize(); ++i) {
    EXPECT_LE(Jt.outerIndexPtr()[i + 1] - Jt.outerIndexPtr()[i], 4);
  }
}

TEST_F(BarycentricMappingTest, ReproducesAffineMapsExactly) {
  const BarycentricMapping J(mesh, points);
  Matrix3d A;
  A << 1.1, 0.2, -0.3, 0.05, 0.9, 0.1, -0.2, 0.3, 1.3;
  const Vector3d b(5, -7, 11);
  const MatrixX3d x = (mesh.nodes() * A.transpose()).rowwise() + b.transpose();
  const MatrixX3d expected = (points * A.transpose()).rowwise() + b.transpose();
  // Linear interpolation is exact for affine fields; only rounding on ~100 mm values remains.
  EXPECT_LT((J.apply(x) - expected).cwiseAbs().maxCoeff(), 1e-12);
}

TEST_F(BarycentricMappingTest, TransposePreservesTotalForceAndMoment) {
  const BarycentricMapping J(mesh, points);
  std::mt19937 rng(3);
  std::normal_distribution<double> g(0.0, 1.0);
  MatrixX3d F(points.rows(), 3);
  for (Eigen::Index i = 0; i < F.size(); ++i) F.data()[i] = g(rng);  // mN
  const MatrixX3d f = J.apply_transposed(F);
  ASSERT_EQ(f.rows(), mesh.num_nodes());
  // Sum of ~500 unit forces: rounding ~1e-13 mN.
  EXPECT_LT((f.colwise().sum() - F.colwise().sum()).norm(), 1e-12);
  // Moment about the origin is preserved too (virtual work of rigid rotations): mN·mm.
  Vector3d m_points = Vector3d::Zero(), m_nodes = Vector3d::Zero();
  for (Eigen::Index i = 0; i < F.rows(); ++i)
    m_points += points.row(i).transpose().cross(F.row(i).transpose());
  for (Eigen::Index i = 0; i < f.rows(); ++i)
    m_nodes += mesh.nodes().row(i).transpose().cross(f.row(i).transpose());
  EXPECT_LT((m_points - m_nodes).norm(), 1e-10);
}

TEST(BarycentricMapping, PointsJustOutsideMapToTheNearestTetWithTheirDistance) {
  const TetMesh box = data_synth::make_box_mesh({10, 20, 30}, {2, 4, 6});
  MatrixX3d P(3, 3);
  P << 3.3, 7.1, -0.7,   // below the bottom face
      11.9, 5.0, 5.0,    // beside the x = 10 face
      11.0, 21.0, 15.0;  // beyond the edge x = 10, y = 20
  const BarycentricMapping J(box, P, {.max_outside_distance = 2.0});
  MatrixX3d closest(3, 3);
  closest << 3.3, 7.1, 0.0, 10.0, 5.0, 5.0, 10.0, 20.0, 15.0;
  // Projections onto axis-aligned faces: rounding only.
  EXPECT_LT((J.apply(box.nodes()) - closest).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_TRUE(tests::near(J.outside_distance()[0], 0.7, 1e-12, 0));
  EXPECT_TRUE(tests::near(J.outside_distance()[1], 1.9, 1e-12, 0));
  EXPECT_TRUE(tests::near(J.outside_distance()[2], std::sqrt(2.0), 1e-12, 0));
}

TEST(BarycentricMapping, FarPointIsAnErrorNamingThePoint) {
  const TetMesh box = data_synth::make_box_mesh({10, 10, 10}, {2, 2, 2});
  MatrixX3d P(4, 3);
  P << 1, 1, 1, 2, 2, 2, 5, 5, 5, 5, 5, 25;  // point 3 is 15 mm above the top
  try {
    const BarycentricMapping J(box, P, {.max_outside_distance = 2.0});
    FAIL() << "a point 15 mm outside was accepted";
  } catch (const Error& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("point 3"), std::string::npos) << msg;
    EXPECT_NE(msg.find("(5, 5, 25)"), std::string::npos) << msg;
    EXPECT_NE(msg.find("15 mm"), std::string::npos) << msg;
  }
}

TEST(BarycentricMapping, NonFinitePointIsAnErrorNamingThePoint) {
  const TetMesh box = data_synth::make_box_mesh({10, 10, 10}, {2, 2, 2});
  MatrixX3d P(2, 3);
  P << 1, 1, 1, 1, std::numeric_limits<double>::quiet_NaN(), 1;
  try {
    const BarycentricMapping J(box, P);
    FAIL() << "a NaN point was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("point 1"), std::string::npos) << e.what();
  }
}

TEST(BarycentricMapping, ApplyChecksShapes) {
  const TetMesh box = data_synth::make_box_mesh({10, 10, 10}, {2, 2, 2});
  const BarycentricMapping J(box, MatrixX3d::Constant(2, 3, 5.0));
  EXPECT_THROW((void)J.apply(MatrixX3d::Zero(3, 3)), Error);
  EXPECT_THROW((void)J.apply_transposed(MatrixX3d::Zero(3, 3)), Error);
}

}  // namespace
}  // namespace brainshift::core
