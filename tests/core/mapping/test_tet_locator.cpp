#include "tolerance.hpp"

#include "core/mapping/tet_locator.hpp"
#include "data_synth/geometry/structured_mesh.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <limits>
#include <random>

namespace brainshift::core {
namespace {

using Tet = Eigen::Matrix<double, 4, 3>;

Tet unit_tet() {
  Tet X;
  X << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1;
  return X;
}

/// Reference point–tetrahedron distance, independent of the locator's face-by-face method:
/// project p onto the affine hull of each of the 15 faces of the simplex (vertices, edges,
/// triangles, the tetrahedron) by least squares and keep the nearest projection whose weights are
/// all non-negative. The nearest point of a simplex is such a projection.
double reference_distance(const Tet& X, const Vector3d& p) {
  double best = std::numeric_limits<double>::infinity();
  for (int mask = 1; mask < 16; ++mask) {
    std::array<int, 4> idx{};
    int n = 0;
    for (int k = 0; k < 4; ++k)
      if (mask & (1 << k)) idx[n++] = k;
    const Vector3d x0 = X.row(idx[0]);
    Eigen::MatrixXd A(3, n - 1);
    for (int k = 1; k < n; ++k) A.col(k - 1) = X.row(idx[k]).transpose() - x0;
    Eigen::VectorXd w = Eigen::VectorXd::Zero(n - 1);
    if (n > 1) w = A.colPivHouseholderQr().solve(p - x0);
    if (n > 1 && (w.minCoeff() < 0.0 || w.sum() > 1.0)) continue;
    const Vector3d q = n > 1 ? Vector3d(x0 + A * w) : x0;
    best = std::min(best, (p - q).norm());
  }
  return best;
}

Vector3d point_of(const Tet& X, const Vector4d& b) { return X.transpose() * b; }

TEST(TetLocator, BarycentricCoordinatesOfTheUnitTetrahedron) {
  const Vector4d b = barycentric_coordinates(unit_tet(), Vector3d(0.1, 0.2, 0.3));
  // A 3×3 solve on exact small numbers: a few ulps.
  EXPECT_LT((b - Vector4d(0.4, 0.1, 0.2, 0.3)).norm(), 8 * tests::eps);
}

struct RegionCase {
  const char* name;
  Vector3d p;
  Vector3d closest;
};

class TetLocatorRegions : public ::testing::TestWithParam<RegionCase> {};

TEST_P(TetLocatorRegions, NearestPointOfOneTetrahedronIsExactInEveryVoronoiRegion) {
  const RegionCase& c = GetParam();
  SCOPED_TRACE(c.name);
  const Tet X = unit_tet();
  MatrixX4i T(1, 4);
  T << 0, 1, 2, 3;
  const TetLocator locator(X, T);
  const auto loc = locator.locate(c.p, /*max_distance=*/10.0);
  ASSERT_TRUE(loc.has_value());
  EXPECT_EQ(loc->tet, 0);
  // Closest points are simple rationals: a few ulps.
  EXPECT_LT((point_of(X, loc->barycentric) - c.closest).norm(), 16 * tests::eps);
  EXPECT_TRUE(tests::near(loc->distance, (c.p - c.closest).norm(), 0, 16 * tests::eps));
  EXPECT_GE(loc->barycentric.minCoeff(), 0.0);
  EXPECT_TRUE(tests::near(loc->barycentric.sum(), 1.0, 0, 4 * tests::eps));
}

INSTANTIATE_TEST_SUITE_P(
    AllRegions, TetLocatorRegions,
    ::testing::Values(RegionCase{"inside", {0.1, 0.2, 0.3}, {0.1, 0.2, 0.3}},
                      RegionCase{"on a vertex", {1, 0, 0}, {1, 0, 0}},
                      RegionCase{"vertex region", {-1, -1, -1}, {0, 0, 0}},
                      RegionCase{"edge region", {0.5, -1, -1}, {0.5, 0, 0}},
                      RegionCase{"face region", {0.2, 0.2, -1}, {0.2, 0.2, 0}},
                      RegionCase{"slanted face", {1, 1, 1}, {1.0 / 3, 1.0 / 3, 1.0 / 3}},
                      RegionCase{"just outside", {0.2, 0.2, -1e-9}, {0.2, 0.2, 0}}));

TEST(TetLocator, FarPointsAreNotLocated) {
  MatrixX4i T(1, 4);
  T << 0, 1, 2, 3;
  const TetLocator locator(unit_tet(), T);
  EXPECT_FALSE(locator.locate(Vector3d(0.2, 0.2, -1.5), 1.0).has_value());
  EXPECT_FALSE(locator.locate(Vector3d(100, 0, 0), 1.0).has_value());
  EXPECT_FALSE(locator.locate(Vector3d::Constant(std::nan("")), 1.0).has_value());
  const auto loc = locator.locate(Vector3d(100, 0, 0), std::numeric_limits<double>::infinity());
  ASSERT_TRUE(loc.has_value());
  EXPECT_TRUE(tests::near(loc->distance, 99.0, 0, 1e-14));
}

TEST(TetLocator, AgreesWithBruteForceOnThousandsOfRandomPointsAroundAnEllipsoid) {
  const Vector3d semi_axes(60, 70, 50);
  const TetMesh mesh = data_synth::make_ellipsoid_mesh(semi_axes, 8);
  const TetLocator locator(mesh.nodes(), mesh.tets());
  constexpr double max_distance = 3.0;  // mm: the "near outside" band
  std::mt19937 rng(42);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  int inside = 0, near_outside = 0, far_outside = 0;
  for (int n = 0; n < 4000; ++n) {
    // Half the points anywhere in the box around the ellipsoid, half close to its surface.
    Vector3d dir(u(rng), u(rng), u(rng));
    Vector3d p = (semi_axes.array() + 5.0).matrix().cwiseProduct(dir);
    if (n % 2 == 1 && dir.norm() > 1e-3) {
      dir.normalize();
      p = (1.0 + 0.06 * u(rng)) * semi_axes.cwiseProduct(dir);
    }
    SCOPED_TRACE(::testing::Message() << "point " << n << " at " << p.transpose());
    double brute = std::numeric_limits<double>::infinity();
    for (index_t t = 0; t < mesh.num_tets() && brute > 0.0; ++t) {
      const Tet X = mesh.tet_nodes(t);
      const Vector3d lo = X.colwise().minCoeff(), hi = X.colwise().maxCoeff();
      if ((p.cwiseMax(lo).cwiseMin(hi) - p).norm() > brute) continue;  // cannot be nearer
      brute = barycentric_coordinates(X, p).minCoeff() >= 0.0
                  ? 0.0
                  : std::min(brute, reference_distance(X, p));
    }
    const auto loc = locator.locate(p, max_distance);
    // Reference and locator round differently: allow 1e-9 mm on distances of ~1 mm.
    constexpr double distance_tol = 1e-9;
    if (std::abs(brute - max_distance) < distance_tol) continue;  // ambiguous by rounding
    if (brute > max_distance) {
      EXPECT_FALSE(loc.has_value());
      ++far_outside;
      continue;
    }
    ASSERT_TRUE(loc.has_value());
    ASSERT_GE(loc->tet, 0);
    ASSERT_LT(loc->tet, mesh.num_tets());
    EXPECT_TRUE(tests::near(loc->distance, brute, distance_tol, 0));
    const Tet X = mesh.tet_nodes(loc->tet);
    EXPECT_GE(loc->barycentric.minCoeff(), 0.0);
    EXPECT_TRUE(tests::near(loc->barycentric.sum(), 1.0, 0, 8 * tests::eps));
    // The reported closest point is at the reported distance, and is the brute-force distance.
    EXPECT_TRUE(tests::near((point_of(X, loc->barycentric) - p).norm(), brute, distance_tol, 0));
    if (brute == 0.0) {
      ++inside;
      EXPECT_EQ(loc->distance, 0.0);
      // Inside: the coordinates reproduce p (cancellation on ~60 mm coordinates).
      EXPECT_LT((point_of(X, loc->barycentric) - p).norm(), 1e-12);
    } else {
      ++near_outside;
    }
  }
  // The sampling must exercise every branch.
  EXPECT_GT(inside, 1000);
  EXPECT_GT(near_outside, 300);
  EXPECT_GT(far_outside, 100);
}

TEST(TetLocator, EveryNodeAndFaceCentroidIsInside) {
  const TetMesh mesh = data_synth::make_cylinder_mesh(20, 80, 6, 8);
  const TetLocator locator(mesh.nodes(), mesh.tets());
  for (index_t i = 0; i < mesh.num_nodes(); ++i) {
    const Vector3d p = mesh.nodes().row(i);
    const auto loc = locator.locate(p, 0.0);
    ASSERT_TRUE(loc.has_value()) << "node " << i;
    EXPECT_EQ(loc->distance, 0.0);
  }
  for (index_t t = 0; t < mesh.num_tets(); ++t) {
    const Tet X = mesh.tet_nodes(t);
    const Vector3d p = (X.row(0) + X.row(1) + X.row(2)) / 3.0;
    const auto loc = locator.locate(p, 0.0);
    ASSERT_TRUE(loc.has_value()) << "face centroid of tet " << t;
    EXPECT_LT((point_of(mesh.tet_nodes(loc->tet), loc->barycentric) - p).norm(), 1e-12);
  }
}

}  // namespace
}  // namespace brainshift::core
