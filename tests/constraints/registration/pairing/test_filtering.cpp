#include "tolerance.hpp"

#include "constraints/registration/pairing/filtering.hpp"

#include <gtest/gtest.h>

#include <numbers>

namespace brainshift::constraints {
namespace {

Pair make_pair(index_t point, index_t feature, double distance,
               Vector3d direction = Vector3d::UnitX()) {
  Pair p;
  p.point = point;
  p.feature = feature;
  p.distance = distance;
  p.direction = direction;
  return p;
}

TEST(Filtering, KeepsTheNearestPointPerFeature) {
  std::vector<Pair> pairs = {make_pair(0, 7, 2.0), make_pair(1, 7, 1.0), make_pair(2, 8, 3.0)};
  FilterOptions o;
  o.median_threshold_mm = 100;
  FilterReport r;
  const auto kept = filter_pairs(pairs, {}, {}, o, &r);
  ASSERT_EQ(kept.size(), 2u);
  EXPECT_EQ(kept[0].point, 1);
  EXPECT_EQ(kept[1].point, 2);
  EXPECT_EQ(r.duplicate_feature, 1);
}

TEST(Filtering, DropsPairsBeyondMedianPlusThresholdAndBelowTheFloor) {
  std::vector<Pair> pairs;
  for (int i = 0; i < 9; ++i) pairs.push_back(make_pair(i, i, 2.0 + 0.1 * i));
  pairs.push_back(make_pair(9, 9, 30.0));    // an outlier
  pairs.push_back(make_pair(10, 10, 0.01));  // already matched
  FilterOptions o;
  o.median_threshold_mm = 5.0;
  o.min_distance_mm = 0.05;
  FilterReport r;
  const auto kept = filter_pairs(pairs, {}, {}, o, &r);
  EXPECT_EQ(r.too_far, 1);
  EXPECT_EQ(r.too_near, 1);
  EXPECT_EQ(kept.size(), 9u);
  EXPECT_TRUE(tests::near(r.median_distance, 2.4, 1e-12, 0));  // 11 values, the 6th smallest
}

TEST(Filtering, DropsVesselPairsWhoseDirectionsDisagree) {
  // Intra-operative points along x; one pair is to a segment along y.
  MatrixX3d pts(8, 3);
  for (int i = 0; i < 8; ++i) pts.row(i) << 1.0 * i, 0.01 * (i % 2), 0;
  const auto dirs = local_directions(pts, 2.5);
  ASSERT_GT(std::abs(dirs[3].x()), 0.99);  // well-defined direction along x
  std::vector<Pair> pairs = {make_pair(3, 0, 1.0, Vector3d::UnitX()),
                             make_pair(4, 1, 1.0, Vector3d::UnitY()),
                             make_pair(5, 2, 1.0, -Vector3d::UnitX())};  // sign does not matter
  FilterOptions o;
  o.max_angle_deg = 30;
  FilterReport r;
  const auto kept = filter_pairs(pairs, dirs, {}, o, &r);
  EXPECT_EQ(r.direction, 1);
  ASSERT_EQ(kept.size(), 2u);
  EXPECT_EQ(kept[1].point, 5);
}

TEST(Filtering, SubsamplesToAtMostOnePairPerTetrahedron) {
  std::vector<Pair> pairs = {make_pair(0, 0, 3.0), make_pair(1, 1, 1.0), make_pair(2, 2, 2.0),
                             make_pair(3, 3, 2.0)};
  const std::vector<index_t> tets = {5, 5, 5, 6};
  FilterOptions o;
  o.median_threshold_mm = 100;
  FilterReport r;
  const auto kept = filter_pairs(pairs, {}, tets, o, &r);
  EXPECT_EQ(r.subsampled, 2);
  ASSERT_EQ(kept.size(), 2u);
  EXPECT_EQ(kept[0].point, 1);  // nearest in tet 5
  EXPECT_EQ(kept[1].point, 3);
}

TEST(Filtering, EmptyInputGivesAnEmptyReport) {
  FilterReport r;
  EXPECT_TRUE(filter_pairs({}, {}, {}, FilterOptions{}, &r).empty());
  EXPECT_EQ(r.input, 0);
  EXPECT_EQ(r.kept, 0);
}

}  // namespace
}  // namespace brainshift::constraints
