#include "tolerance.hpp"

#include "constraints/registration/pairing/pairing.hpp"

#include <gtest/gtest.h>

#include <random>

namespace brainshift::constraints {
namespace {

/// A random polyline "vessel" of n segments with 2.5 mm steps, seeded.
core::Skeleton random_skeleton(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> g;
  core::Skeleton s;
  s.points.resize(n + 1, 3);
  Vector3d p = Vector3d::Zero(), d = Vector3d::UnitX();
  for (int i = 0; i <= n; ++i) {
    s.points.row(i) = p.transpose();
    d = (d + 0.4 * Vector3d(g(rng), g(rng), g(rng))).normalized();
    p += 2.5 * d;
    if (i < n) s.segments.push_back({i, i + 1});
  }
  return s;
}

TEST(FeatureIndex, NearestSegmentAgreesWithBruteForce) {
  const core::Skeleton s = random_skeleton(400, 1);
  const FeatureIndex index = FeatureIndex::segments(s.points, s.segments);
  std::mt19937 rng(2);
  const Vector3d lo = s.points.colwise().minCoeff().transpose().array() - 10;
  const Vector3d hi = s.points.colwise().maxCoeff().transpose().array() + 10;
  std::uniform_real_distribution<double> u(0, 1);
  int found = 0;
  for (int k = 0; k < 2000; ++k) {
    const Vector3d q = lo + (hi - lo).cwiseProduct(Vector3d(u(rng), u(rng), u(rng)));
    double best = std::numeric_limits<double>::infinity();
    for (std::size_t f = 0; f < s.segments.size(); ++f) {
      const Vector3d a = s.points.row(s.segments[f][0]), b = s.points.row(s.segments[f][1]);
      const double t = std::clamp((q - a).dot(b - a) / (b - a).squaredNorm(), 0.0, 1.0);
      best = std::min(best, (q - (a + t * (b - a))).norm());
    }
    const auto hit = index.nearest(q, 8.0);
    SCOPED_TRACE(k);
    if (best <= 8.0) {
      ASSERT_TRUE(hit.has_value());
      // Same distance up to rounding (ties between segments may pick either one).
      EXPECT_TRUE(tests::near(hit->distance, best, 1e-12, 1e-12));
      EXPECT_TRUE(tests::near((q - hit->closest).norm(), hit->distance, 1e-12, 1e-12));
      ++found;
    } else {
      EXPECT_FALSE(hit.has_value());
    }
  }
  EXPECT_GT(found, 100);  // the sample exercises both branches
}

TEST(FeatureIndex, TrianglePairsCarryTheNormalAndBarycentricWeights) {
  MatrixX3d v(4, 3);
  v << 0, 0, 0, 10, 0, 0, 0, 10, 0, 10, 10, 0;
  Eigen::Matrix<index_t, Eigen::Dynamic, 3, Eigen::RowMajor> t(2, 3);
  t << 0, 1, 2, 1, 3, 2;
  const FeatureIndex index = FeatureIndex::triangles(v, t);
  const auto hit = index.nearest(Vector3d(2, 3, 4), 10.0);
  ASSERT_TRUE(hit.has_value());
  EXPECT_EQ(hit->feature, 0);
  EXPECT_TRUE(tests::near(hit->distance, 4.0, 1e-14, 0));
  EXPECT_TRUE(tests::near(std::abs(hit->direction.z()), 1.0, 1e-14, 0));
  EXPECT_LT((hit->weights - Vector3d(0.5, 0.2, 0.3)).norm(), 1e-14);
}

TEST(FeatureIndex, EmptyFeatureSetsAndNonFiniteQueriesPairNothing) {
  const FeatureIndex empty = FeatureIndex::segments(MatrixX3d(0, 3), {});
  EXPECT_FALSE(empty.nearest(Vector3d::Zero(), 100).has_value());
  const core::Skeleton s = random_skeleton(5, 3);
  const FeatureIndex index = FeatureIndex::segments(s.points, s.segments);
  EXPECT_FALSE(index.nearest(Vector3d(NAN, 0, 0), 100).has_value());
  EXPECT_TRUE(index.pair(MatrixX3d(0, 3), 10).empty());
}

}  // namespace
}  // namespace brainshift::constraints
