#include "expect_error.hpp"
#include "random_rotation.hpp"
#include "tolerance.hpp"

#include "core/mapping/closest_point.hpp"
#include "imaging/evaluation/metrics.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <iostream>
#include <limits>
#include <map>
#include <random>
#include <utility>

namespace brainshift::imaging {
namespace {

using core::SurfaceMesh;

/// Icosphere: the icosahedron subdivided `levels` times, every vertex projected onto the sphere
/// of radius `radius` about `centre` (so vertices lie on the sphere and faces inside it).
SurfaceMesh icosphere(int levels, double radius, const Vector3d& centre = Vector3d::Zero()) {
  const double t = (1.0 + std::sqrt(5.0)) / 2.0;
  std::vector<Vector3d> v = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0},
                             {0, -1, t}, {0, 1, t}, {0, -1, -t}, {0, 1, -t},
                             {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  std::vector<std::array<int, 3>> f = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                       {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                       {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                       {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
  for (auto& x : v) x.normalize();
  for (int l = 0; l < levels; ++l) {
    std::map<std::pair<int, int>, int> mid;
    const auto midpoint = [&](int a, int b) {
      const auto key = std::minmax(a, b);
      const auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      v.push_back((v[std::size_t(a)] + v[std::size_t(b)]).normalized());
      return mid[key] = int(v.size()) - 1;
    };
    std::vector<std::array<int, 3>> next;
    for (const auto& [a, b, c] : f) {
      const int ab = midpoint(a, b);
      const int bc = midpoint(b, c);
      const int ca = midpoint(c, a);
      next.push_back({a, ab, ca});
      next.push_back({b, bc, ab});
      next.push_back({c, ca, bc});
      next.push_back({ab, bc, ca});
    }
    f.swap(next);
  }
  SurfaceMesh s;
  s.vertices.resize(Eigen::Index(v.size()), 3);
  for (std::size_t i = 0; i < v.size(); ++i)
    s.vertices.row(Eigen::Index(i)) = (centre + radius * v[i]).transpose();
  s.triangles.resize(Eigen::Index(f.size()), 3);
  for (std::size_t i = 0; i < f.size(); ++i)
    s.triangles.row(Eigen::Index(i)) << f[i][0], f[i][1], f[i][2];
  return s;
}

/// Chord error of a sphere mesh: radius − the smallest distance from the centre to a triangle.
/// The mesh lies in the shell [radius − sag, radius], and its radial projection covers the sphere,
/// so mesh and sphere are within `sag` of each other.
double chord_sag(const SurfaceMesh& s, double radius, const Vector3d& centre) {
  double inner = radius;
  for (Eigen::Index f = 0; f < s.triangles.rows(); ++f) {
    const Vector3d a = s.vertices.row(s.triangles(f, 0)).transpose();
    const Vector3d b = s.vertices.row(s.triangles(f, 1)).transpose();
    const Vector3d c = s.vertices.row(s.triangles(f, 2)).transpose();
    const Vector3d w = core::closest_point_on_triangle(centre, a, b, c);
    inner = std::min(inner, (w[0] * a + w[1] * b + w[2] * c - centre).norm());
  }
  return radius - inner;
}

/// Brute-force reference of surface_distances().
std::vector<double> brute_force_distances(const SurfaceMesh& from, const SurfaceMesh& to) {
  std::vector<double> d(std::size_t(from.vertices.rows()), 1e300);
  for (Eigen::Index v = 0; v < from.vertices.rows(); ++v) {
    const Vector3d p = from.vertices.row(v).transpose();
    for (Eigen::Index f = 0; f < to.triangles.rows(); ++f) {
      const Vector3d a = to.vertices.row(to.triangles(f, 0)).transpose();
      const Vector3d b = to.vertices.row(to.triangles(f, 1)).transpose();
      const Vector3d c = to.vertices.row(to.triangles(f, 2)).transpose();
      const Vector3d w = core::closest_point_on_triangle(p, a, b, c);
      d[std::size_t(v)] = std::min(d[std::size_t(v)], (w[0] * a + w[1] * b + w[2] * c - p).norm());
    }
  }
  return d;
}

/// A flat n × n vertex grid of spacing h in the plane z = 0, then the map p → R p + t.
SurfaceMesh flat_grid(int n, double h, double x0, const Matrix3d& R, const Vector3d& t,
                      double slope = 0.0, double offset = 0.0) {
  SurfaceMesh s;
  s.vertices.resize(n * n, 3);
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const double x = x0 + i * h;
      const Vector3d p(x, x0 + j * h, offset + slope * x);
      s.vertices.row(j * n + i) = (R * p + t).transpose();
    }
  s.triangles.resize(2 * (n - 1) * (n - 1), 3);
  int f = 0;
  for (int j = 0; j + 1 < n; ++j)
    for (int i = 0; i + 1 < n; ++i) {
      const int a = j * n + i;
      s.triangles.row(f++) << a, a + 1, a + n + 1;
      s.triangles.row(f++) << a, a + n + 1, a + n;
    }
  return s;
}

TEST(Percentile, IsLinearBetweenOrderStatistics) {
  // Values of NumPy's default (linear) rule, exact in binary up to one rounding.
  const std::vector<double> x = {4.0, 1.0, 3.0, 2.0};
  EXPECT_TRUE(tests::near(percentile(x, 0.0), 1.0, 0.0, 0.0));
  EXPECT_TRUE(tests::near(percentile(x, 100.0), 4.0, 0.0, 0.0));
  EXPECT_TRUE(tests::near(percentile(x, 50.0), 2.5, 0.0, 4 * tests::eps));
  EXPECT_TRUE(tests::near(percentile(x, 95.0), 3.85, 0.0, 4 * tests::eps));  // h = 2.85
  EXPECT_TRUE(tests::near(percentile(x, 25.0), 1.75, 0.0, 4 * tests::eps));  // h = 0.75
  EXPECT_EQ(percentile({7.0}, 95.0), 7.0);
  tests::expect_error([] { (void)percentile({}, 50.0); }, {"empty"});
  tests::expect_error([] { (void)percentile({1.0}, 101.0); }, {"101"});
}

TEST(Percentile, SelectionGivesExactlyTheSortedAnswer) {
  // percentile() selects the two order statistics instead of sorting: against the type-7 rule
  // on a sorted copy, bit for bit (the same two values enter the same formula), on samples with
  // many ties (integers 0..19) and without, at the ends and between order statistics.
  std::mt19937 rng(14);
  for (const std::size_t n : {std::size_t(1), std::size_t(2), std::size_t(7), std::size_t(1000)})
    for (const bool ties : {true, false}) {
      std::vector<double> x(n);
      std::uniform_real_distribution<double> u(-5.0, 5.0);
      std::uniform_int_distribution<int> k(0, 19);
      for (double& v : x) v = ties ? double(k(rng)) : u(rng);
      std::vector<double> sorted = x;
      std::sort(sorted.begin(), sorted.end());
      for (const double p : {0.0, 1.0, 25.0, 50.0, 95.0, 99.9, 100.0}) {
        SCOPED_TRACE(testing::Message() << "n " << n << " ties " << ties << " p " << p);
        const double h = double(n - 1) * p / 100.0;
        const auto lo = std::size_t(std::floor(h));
        const std::size_t hi = std::min(lo + 1, n - 1);
        const double expected = sorted[lo] + (h - double(lo)) * (sorted[hi] - sorted[lo]);
        EXPECT_EQ(percentile(x, p), expected);
      }
    }
}

TEST(ErrorStats, SummarisesAndHandlesTheEmptySet) {
  const ErrorStats s = error_stats({1.0, 5.0, 2.0, 3.0, 4.0});
  EXPECT_FALSE(s.empty);
  EXPECT_EQ(s.count, 5u);
  EXPECT_TRUE(tests::near(s.mean, 3.0, 0.0, 4 * tests::eps));
  EXPECT_EQ(s.median, 3.0);
  EXPECT_TRUE(tests::near(s.p95, 4.8, 0.0, 4 * tests::eps));  // h = 3.8
  EXPECT_EQ(s.max, 5.0);

  const ErrorStats e = error_stats({});
  EXPECT_TRUE(e.empty);
  EXPECT_EQ(e.count, 0u);
  EXPECT_EQ(e.mean, 0.0);
  EXPECT_EQ(e.median, 0.0);
  EXPECT_EQ(e.p95, 0.0);
  EXPECT_EQ(e.max, 0.0);
  tests::expect_error([] { (void)error_stats({1.0, -2.0}); }, {"error 1", "-2"});
  tests::expect_error([] { (void)error_stats({std::nan("")}); }, {"error 0"});
}

TEST(LandmarkErrors, AreRowWiseDistances) {
  MatrixX3d a(2, 3);
  MatrixX3d b(2, 3);
  a << 0, 0, 0, 1, 1, 1;
  b << 3, 4, 0, 1, 1, 3;
  const auto e = landmark_errors(a, b);
  ASSERT_EQ(e.size(), 2u);
  EXPECT_EQ(e[0], 5.0);
  EXPECT_EQ(e[1], 2.0);
  MatrixX3d c(3, 3);
  c.setZero();
  tests::expect_error([&] { (void)landmark_errors(c, b); }, {"3 predicted", "2 true"});
}

TEST(MatchLandmarks, PairsByIdAndReportsTheUnpaired) {
  MatrixX3d a(3, 3);
  MatrixX3d b(3, 3);
  a << 1, 0, 0, 2, 0, 0, 3, 0, 0;
  b << 30, 0, 0, 10, 0, 0, 40, 0, 0;
  const LandmarkPairs p = match_landmarks_by_id({"1", "2", "3"}, a, {"3", "1", "4"}, b);
  ASSERT_EQ(p.ids, (std::vector<std::string>{"1", "3"}));
  EXPECT_EQ(p.a(0, 0), 1.0);
  EXPECT_EQ(p.b(0, 0), 10.0);
  EXPECT_EQ(p.a(1, 0), 3.0);
  EXPECT_EQ(p.b(1, 0), 30.0);
  EXPECT_EQ(p.only_in_a, std::vector<std::string>{"2"});
  EXPECT_EQ(p.only_in_b, std::vector<std::string>{"4"});
  EXPECT_EQ(p.warnings.size(), 2u);
  tests::expect_error(
      [&] {
        (void)match_landmarks_by_id({"1", "1", "3"}, a, {"1"}, b.topRows(1));
      },
      {"'1'", "twice", "set A"});
  tests::expect_error([&] { (void)match_landmarks_by_id({"1"}, a, {"1"}, b.topRows(1)); },
                      {"1 ids", "3 points"});
}

TEST(Hausdorff, ConcentricSpheresAreTwoMillimetresApartUpToTheChordError) {
  // Radii 30 and 32 mm. For a vertex of the inner mesh (on its sphere) the distance to the outer
  // mesh lies in [2 − sag_outer, 2] and for an outer vertex to the inner mesh in [2, 2 + sag_inner]
  // (the meshes lie in the shells [R − sag, R]; see chord_sag()). Exact bounds, so every pooled
  // distance and each percentile must be inside them (+ 1e-12 mm of rounding).
  const SurfaceMesh inner = icosphere(4, 30.0);
  const SurfaceMesh outer = icosphere(4, 32.0);
  const double sag_inner = chord_sag(inner, 30.0, Vector3d::Zero());
  const double sag_outer = chord_sag(outer, 32.0, Vector3d::Zero());
  std::cout << "[ measured ] icosphere level 4: " << inner.vertices.rows()
            << " vertices, chord sag " << sag_inner << " / " << sag_outer << " mm\n";
  ASSERT_LT(sag_outer, 0.1);
  const double lo = 2.0 - sag_outer - 1e-12;
  const double hi = 2.0 + sag_inner + 1e-12;
  for (double d : surface_distances(inner, outer)) ASSERT_TRUE(d >= lo && d <= 2.0 + 1e-12) << d;
  for (double d : surface_distances(outer, inner)) ASSERT_TRUE(d >= 2.0 - 1e-12 && d <= hi) << d;
  const SurfaceDistanceStats s = hausdorff_percentiles(inner, outer);
  EXPECT_EQ(s.count, std::size_t(inner.vertices.rows() + outer.vertices.rows()));
  for (double h : {s.h95, s.h75, s.h50, s.h25, s.max, s.mean}) {
    EXPECT_GE(h, lo);
    EXPECT_LE(h, hi);
  }
}

TEST(Hausdorff, TranslatedSphereMatchesTheExactSphereDistancesWithinTheChordError) {
  // Sphere A (radius 30 about 0) and its copy B translated by t. The exact distance from a
  // point p of sphere A to sphere B is | ‖p − t‖ − 30 |; a mesh is within its chord sag of its
  // sphere, so each directed distance is within sag_B of the exact one, and (percentiles being
  // 1-Lipschitz in the sup norm of the sample) each Hxx within max(sag_A, sag_B) of the exact
  // pooled percentile.
  const Vector3d t(1.5, -0.8, 0.6);
  const SurfaceMesh a = icosphere(4, 30.0);
  const SurfaceMesh b = icosphere(4, 30.0, t);
  const double sag = std::max(chord_sag(a, 30.0, Vector3d::Zero()), chord_sag(b, 30.0, t));
  std::vector<double> exact;
  for (Eigen::Index v = 0; v < a.vertices.rows(); ++v)
    exact.push_back(std::abs((a.vertices.row(v).transpose() - t).norm() - 30.0));
  for (Eigen::Index v = 0; v < b.vertices.rows(); ++v)
    exact.push_back(std::abs(b.vertices.row(v).norm() - 30.0));
  const auto ab = surface_distances(a, b);
  for (std::size_t v = 0; v < ab.size(); ++v) EXPECT_NEAR(ab[v], exact[v], sag + 1e-12);
  const SurfaceDistanceStats s = hausdorff_percentiles(a, b);
  EXPECT_NEAR(s.h95, percentile(exact, 95.0), sag + 1e-12);
  EXPECT_NEAR(s.h75, percentile(exact, 75.0), sag + 1e-12);
  EXPECT_NEAR(s.h50, percentile(exact, 50.0), sag + 1e-12);
  EXPECT_NEAR(s.h25, percentile(exact, 25.0), sag + 1e-12);
  EXPECT_NEAR(s.max, percentile(exact, 100.0), sag + 1e-12);
  EXPECT_LE(s.max, t.norm() + sag);  // the sphere-to-sphere maximum is |t|
  std::cout << "[ measured ] translated sphere |t| = " << t.norm() << ": H95 " << s.h95 << ", H50 "
            << s.h50 << ", max " << s.max << " mm\n";
}

TEST(Hausdorff, TiltedPlaneDistancesAreExact) {
  // A: 21 × 21 grid on [0, 20]² at z = 0; B: the plane z = 5 + 0.2 x over [−40, 60]², large
  // enough that each foot point lies inside it; both rigidly moved. Distance from (x, y, 0) to
  // B is (5 + 0.2 x)/√1.04, exact up to rounding (1e-12 mm at these magnitudes).
  std::mt19937 rng(4);
  const Matrix3d R = tests::random_rotation(rng);
  const Vector3d t(12.0, -7.0, 30.0);
  const SurfaceMesh a = flat_grid(21, 1.0, 0.0, R, t);
  const SurfaceMesh b = flat_grid(26, 4.0, -40.0, R, t, /*slope=*/0.2, /*offset=*/5.0);
  const auto d = surface_distances(a, b);
  for (int j = 0; j < 21; ++j)
    for (int i = 0; i < 21; ++i)
      EXPECT_NEAR(d[std::size_t(j * 21 + i)], (5.0 + 0.2 * i) / std::sqrt(1.04), 1e-12);
}

TEST(Hausdorff, IdenticalSurfacesAreZeroApart) {
  const SurfaceMesh a = icosphere(3, 25.0, Vector3d(3, 4, 5));
  const SurfaceDistanceStats s = hausdorff_percentiles(a, a);
  EXPECT_EQ(s.max, 0.0);
  EXPECT_EQ(s.mean, 0.0);
  EXPECT_EQ(s.h95, 0.0);
}

TEST(Hausdorff, GridSearchEqualsBruteForce) {
  // Bumpy spheres of different sizes and centres, and query points far outside the target's
  // box (the grid's clamped path): the pruned search must find exactly the brute-force minimum.
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> bump(-1.5, 1.5);
  SurfaceMesh a = icosphere(3, 20.0);
  SurfaceMesh b = icosphere(2, 24.0, Vector3d(4, -3, 2));
  for (Eigen::Index v = 0; v < a.vertices.rows(); ++v) a.vertices.row(v) *= 1.0 + bump(rng) / 20.0;
  for (Eigen::Index v = 0; v < b.vertices.rows(); ++v)
    b.vertices.row(v) += bump(rng) * Eigen::RowVector3d::UnitZ();
  SurfaceMesh far = a;
  far.vertices.array() *= 3.0;
  for (const auto& [from, to] : {std::pair{&a, &b}, std::pair{&b, &a}, std::pair{&far, &b}}) {
    const auto fast = surface_distances(*from, *to);
    const auto slow = brute_force_distances(*from, *to);
    ASSERT_EQ(fast.size(), slow.size());
    for (std::size_t v = 0; v < fast.size(); ++v) ASSERT_EQ(fast[v], slow[v]) << "vertex " << v;
  }
}

TEST(Hausdorff, BadSurfacesAreErrors) {
  SurfaceMesh a = icosphere(1, 10.0);
  SurfaceMesh none;
  none.vertices = a.vertices;
  tests::expect_error([&] { (void)surface_distances(a, none); }, {"no triangle"});
  SurfaceMesh bad = a;
  bad.triangles(3, 1) = 999;
  tests::expect_error([&] { (void)hausdorff_percentiles(a, bad); }, {"triangle 3", "999"});
}

TEST(PercentShiftCorrected, IsTheRelativeReductionOfTheMeanTre) {
  EXPECT_TRUE(tests::near(*percent_shift_corrected(10.0, 2.0), 80.0, 0.0, 4 * tests::eps));
  EXPECT_TRUE(tests::near(*percent_shift_corrected(10.0, 12.0), -20.0, 0.0, 4 * tests::eps));
  EXPECT_EQ(*percent_shift_corrected(4.0, 0.0), 100.0);
  EXPECT_FALSE(percent_shift_corrected(0.0, 1.0).has_value());
  EXPECT_FALSE(percent_shift_corrected(1e-4, 1.0).has_value());  // below the 1 µm guard
  tests::expect_error([] { (void)percent_shift_corrected(-1.0, 1.0); }, {"before", "-1"});
}

}  // namespace
}  // namespace brainshift::imaging
