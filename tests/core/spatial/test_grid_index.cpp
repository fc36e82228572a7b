#include "core/error.hpp"
#include "core/spatial/grid_index.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

namespace brainshift::core {
namespace {

/// Random boxes of mixed sizes (0 to 6 mm) in a 40 mm cube, and one "item point" inside each box
/// (the item's geometry: its distance to a query is ≥ the box distance, as GridIndex requires).
struct RandomItems {
  MatrixX3d lo;
  MatrixX3d hi;
  MatrixX3d inside;
};

RandomItems random_items(int n, unsigned seed, double flat_z = -1.0) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> pos(-20.0, 20.0);
  std::uniform_real_distribution<double> size(0.0, 6.0);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  RandomItems r{MatrixX3d(n, 3), MatrixX3d(n, 3), MatrixX3d(n, 3)};
  for (int i = 0; i < n; ++i)
    for (int a = 0; a < 3; ++a) {
      r.lo(i, a) = pos(rng);
      r.hi(i, a) = r.lo(i, a) + (i % 5 == 0 ? 0.0 : size(rng));  // every 5th item is a point
      if (a == 2 && flat_z >= 0.0) r.lo(i, a) = r.hi(i, a) = flat_z;
      r.inside(i, a) = r.lo(i, a) + unit(rng) * (r.hi(i, a) - r.lo(i, a));
    }
  return r;
}

double box_squared_distance(const RandomItems& r, int i, const Vector3d& p) {
  const Vector3d lo = r.lo.row(i).transpose();
  const Vector3d hi = r.hi.row(i).transpose();
  return (p.cwiseMax(lo).cwiseMin(hi) - p).squaredNorm();
}

std::vector<Vector3d> random_queries(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> pos(-35.0, 35.0);  // some outside the items' bounds
  std::vector<Vector3d> q(static_cast<std::size_t>(n));
  for (auto& p : q) p = Vector3d(pos(rng), pos(rng), pos(rng));
  return q;
}

/// Brute-force nearest: lowest index among equal distances, within max_distance inclusive.
std::optional<GridNearest> brute_nearest(const MatrixX3d& pts, const Vector3d& p, double max_d) {
  std::optional<GridNearest> best;
  for (index_t i = 0; i < pts.rows(); ++i) {
    const double d = (pts.row(i).transpose() - p).norm();
    if (d <= max_d && (!best || d < best->distance)) best = GridNearest{i, d};
  }
  return best;
}

void expect_queries_match_brute_force(const RandomItems& r, unsigned seed) {
  const GridIndex grid(r.lo, r.hi);
  ASSERT_EQ(grid.size(), r.lo.rows());
  // The memory bound of the cell-size heuristic.
  EXPECT_LE(grid.dims().cast<double>().prod(), 8.0 * r.lo.rows() + 1.0);
  for (const Vector3d& p : random_queries(300, seed)) {
    for (const double radius : {0.0, 0.7, 3.0, 12.0, std::numeric_limits<double>::infinity()}) {
      std::vector<index_t> expected;
      for (index_t i = 0; i < r.lo.rows(); ++i)
        if (box_squared_distance(r, i, p) <= radius * radius) expected.push_back(i);
      // Exact set equality: the grid only narrows the cells to look in; the box test is the same
      // arithmetic as here.
      EXPECT_EQ(grid.items_within(p, radius), expected) << "p " << p.transpose() << " r " << radius;
    }
    const auto dist = [&](index_t i) { return (r.inside.row(i).transpose() - p).norm(); };
    for (const double max_d : {1.0, 5.0, std::numeric_limits<double>::infinity()}) {
      const auto got = grid.nearest(p, max_d, dist);
      const auto want = brute_nearest(r.inside, p, max_d);
      ASSERT_EQ(got.has_value(), want.has_value()) << "p " << p.transpose() << " max " << max_d;
      if (!want) continue;
      // Exact: the same distance function evaluated on the same item gives the same double.
      EXPECT_EQ(got->item, want->item);
      EXPECT_EQ(got->distance, want->distance);
    }
    // Every item whose box contains p is listed in p's cell (ascending).
    const auto cell = grid.cell_items(p);
    EXPECT_TRUE(std::is_sorted(cell.begin(), cell.end()));
    for (index_t i = 0; i < r.lo.rows(); ++i)
      if (box_squared_distance(r, i, p) == 0.0) {
        EXPECT_NE(std::find(cell.begin(), cell.end(), i), cell.end()) << "box " << i;
      }
  }
}

TEST(GridIndex, RandomBoxesMatchBruteForce) {
  for (const int n : {1, 7, 200, 1500})
    expect_queries_match_brute_force(random_items(n, 11u + n), 3u);
}

TEST(GridIndex, FlatInputMatchesBruteForce) {
  const RandomItems r = random_items(300, 5u, /*flat_z=*/2.5);
  const GridIndex grid(r.lo, r.hi);
  EXPECT_EQ(grid.dims().z(), 1);  // no extent along z: one layer of cells
  expect_queries_match_brute_force(r, 8u);
}

TEST(GridIndex, PointsMatchBruteForce) {
  const RandomItems r = random_items(500, 21u);
  const GridIndex grid = GridIndex::of_points(r.inside);
  for (const Vector3d& p : random_queries(300, 4u)) {
    const auto dist = [&](index_t i) { return (r.inside.row(i).transpose() - p).norm(); };
    const auto got = grid.nearest(p, std::numeric_limits<double>::infinity(), dist);
    const auto want = brute_nearest(r.inside, p, std::numeric_limits<double>::infinity());
    ASSERT_TRUE(got && want);          // 500 points, no distance limit: always one
    EXPECT_EQ(got->item, want->item);  // exact: same arithmetic on the same point
    EXPECT_EQ(got->distance, want->distance);
  }
}

TEST(GridIndex, EmptyIndexFindsNothing) {
  for (const GridIndex& grid : {GridIndex(), GridIndex(MatrixX3d(0, 3), MatrixX3d(0, 3))}) {
    EXPECT_EQ(grid.size(), 0);
    EXPECT_TRUE(grid.items_within(Vector3d::Zero(), 1e9).empty());
    EXPECT_TRUE(grid.cell_items(Vector3d::Zero()).empty());
    EXPECT_FALSE(grid.nearest(Vector3d::Zero(), 1e9, [](index_t) { return 0.0; }));
  }
}

TEST(GridIndex, OnePointAndAllPointsEqual) {
  const MatrixX3d one = Vector3d(1, 2, 3).transpose();
  const GridIndex single = GridIndex::of_points(one);
  EXPECT_EQ(single.dims(), Eigen::Vector3i::Ones());  // a single point: one cell
  const auto d1 = [&](index_t i) { return (one.row(i).transpose() - Vector3d(4, 6, 3)).norm(); };
  const auto hit = single.nearest(Vector3d(4, 6, 3), 5.0, d1);
  ASSERT_TRUE(hit);
  EXPECT_EQ(hit->item, 0);
  EXPECT_EQ(hit->distance, 5.0);                               // 3-4-5 triangle, exact in double
  EXPECT_FALSE(single.nearest(Vector3d(4, 6, 3), 4.999, d1));  // beyond max_distance
  EXPECT_EQ(single.items_within(Vector3d(4, 6, 3), 5.0), std::vector<index_t>{0});
  EXPECT_TRUE(single.items_within(Vector3d(4, 6, 3), 4.999).empty());

  const MatrixX3d same = Vector3d(-7, 0.5, 9).transpose().replicate(50, 1);
  const GridIndex grid = GridIndex::of_points(same);
  EXPECT_EQ(grid.dims(), Eigen::Vector3i::Ones());  // no extent at all: one cell
  const Vector3d q(0, 0, 0);
  const auto d = [&](index_t i) { return (same.row(i).transpose() - q).norm(); };
  const auto tie = grid.nearest(q, std::numeric_limits<double>::infinity(), d);
  ASSERT_TRUE(tie);
  EXPECT_EQ(tie->item, 0);  // 50 equal distances: the lowest index wins
  EXPECT_EQ(grid.items_within(q, 1e3).size(), 50u);
  EXPECT_EQ(grid.cell_items(Vector3d(-7, 0.5, 9)).size(), 50u);
}

TEST(GridIndex, BadQueriesFindNothingAndBadBoxesThrow) {
  const RandomItems r = random_items(50, 2u);
  const GridIndex grid(r.lo, r.hi);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const auto d = [](index_t) { return 1.0; };
  EXPECT_FALSE(grid.nearest(Vector3d(nan, 0, 0), 10.0, d));
  EXPECT_FALSE(grid.nearest(Vector3d::Zero(), nan, d));
  EXPECT_FALSE(grid.nearest(Vector3d::Zero(), -1.0, d));
  EXPECT_TRUE(grid.items_within(Vector3d(0, nan, 0), 10.0).empty());
  EXPECT_TRUE(grid.items_within(Vector3d::Zero(), nan).empty());
  EXPECT_TRUE(grid.items_within(Vector3d::Zero(), -1.0).empty());
  EXPECT_TRUE(grid.cell_items(Vector3d(1e300, 0, 0)).empty());  // far outside the grid
  // A far query still finds the nearest item (shells grow until the whole grid is searched).
  const Vector3d far(1e6, -1e6, 3e5);
  const auto dist = [&](index_t i) { return (r.inside.row(i).transpose() - far).norm(); };
  const auto got = grid.nearest(far, std::numeric_limits<double>::infinity(), dist);
  const auto want = brute_nearest(r.inside, far, std::numeric_limits<double>::infinity());
  ASSERT_TRUE(got && want);
  EXPECT_EQ(got->item, want->item);  // exact: same arithmetic

  MatrixX3d lo = r.lo;
  lo(3, 1) = std::numeric_limits<double>::infinity();
  EXPECT_THROW(GridIndex(lo, r.hi), Error);
  lo = r.hi;
  lo(4, 0) += 1.0;  // lower corner above the upper one
  EXPECT_THROW(GridIndex(lo, r.hi), Error);
  EXPECT_THROW(GridIndex(r.lo, r.hi.topRows(3)), Error);
}

// Ties at a shared vertex go to the lowest index, as the header says. A random tree of segments
// (each new point 2.5 mm from one of the last six): a query whose closest point on several
// segments is their shared vertex is at exactly the same distance from each (the vertex itself,
// the same subtraction), and that distance equals the distance to their boxes' common corner,
// where the squared box distance can round either side of the square of the exact distance. The
// search must not prune a box at exactly the best distance. Brute force: the lowest index among
// the least distances, by the same distance function.
TEST(GridIndex, TiesAtASharedVertexGoToTheLowestIndex) {
  std::mt19937 rng(5);
  std::normal_distribution<double> g;
  const int n = 300;
  MatrixX3d pts(n + 1, 3);
  pts.row(0).setZero();
  std::vector<std::array<index_t, 2>> seg;
  for (int i = 1; i <= n; ++i) {
    const int parent = std::uniform_int_distribution<int>(std::max(0, i - 6), i - 1)(rng);
    pts.row(i) = pts.row(parent) + 2.5 * Vector3d(g(rng), g(rng), g(rng)).normalized().transpose();
    seg.push_back(std::uniform_int_distribution<int>(0, 1)(rng)
                      ? std::array<index_t, 2>{parent, i}
                      : std::array<index_t, 2>{i, parent});
  }
  MatrixX3d lo(n, 3), hi(n, 3);
  for (int f = 0; f < n; ++f) {
    lo.row(f) = pts.row(seg[f][0]).cwiseMin(pts.row(seg[f][1]));
    hi.row(f) = pts.row(seg[f][0]).cwiseMax(pts.row(seg[f][1]));
  }
  const GridIndex index(lo, hi);
  Vector3d q;
  const auto distance = [&](index_t f) {
    const Vector3d a = pts.row(seg[f][0]).transpose(), b = pts.row(seg[f][1]).transpose();
    const double t = std::clamp((q - a).dot(b - a) / (b - a).squaredNorm(), 0.0, 1.0);
    const Vector3d c = t == 0.0 ? a : t == 1.0 ? b : Vector3d(a + t * (b - a));
    return (q - c).norm();
  };
  std::uniform_real_distribution<double> u(0, 1);
  const Vector3d box_lo = pts.colwise().minCoeff().transpose().array() - 6.0;
  const Vector3d box_hi = pts.colwise().maxCoeff().transpose().array() + 6.0;
  int ties = 0;
  for (int k = 0; k < 3000; ++k) {
    q = box_lo + (box_hi - box_lo).cwiseProduct(Vector3d(u(rng), u(rng), u(rng)));
    index_t best = 0;
    int at_best = 1;
    for (index_t f = 1; f < n; ++f) {
      const double d = distance(f), db = distance(best);
      if (d < db)
        best = f, at_best = 1;
      else if (d == db)
        ++at_best;
    }
    ties += at_best > 1;
    const auto hit = index.nearest(q, std::numeric_limits<double>::infinity(), distance);
    ASSERT_TRUE(hit.has_value());
    EXPECT_EQ(hit->item, best) << "query " << k << ", " << at_best
                               << " items at the least distance";
    EXPECT_EQ(hit->distance, distance(best));
  }
  EXPECT_GT(ties, 100);  // the sample exercises exact ties
}

}  // namespace
}  // namespace brainshift::core
