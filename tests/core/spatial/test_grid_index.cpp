#include "core/error.hpp"
#include "core/spatial/grid_index.hpp"

#include <gtest/gtest.h>

#include <algorithm>
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

}  // namespace
}  // namespace brainshift::core
