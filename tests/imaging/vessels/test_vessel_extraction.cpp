#include "imaging/vessels/vessel_extraction.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "core/logger.hpp"
#include "expect_error.hpp"
#include "synthetic_tubes.hpp"

namespace brainshift::imaging {
namespace {

using tests::AxisSegment;
using tests::distance_to_axes;
using tests::draw_tubes;
using tests::unit_grid;

/// Options that skip resampling so the tests see every centreline point.
VesselExtractionOptions given_threshold(double threshold = 500.0) {
  VesselExtractionOptions o;
  o.threshold = threshold;
  o.resample_step_mm = 0.0;
  return o;
}

/// Largest distance from the graph's branch points to the axes, ignoring points within
/// `exclude_mm` of any of `excluded` (junction regions, where a thinned centreline rounds the
/// corner).
double worst_axis_distance(const VesselGraph& graph, const std::vector<AxisSegment>& axes,
                           const std::vector<Vector3d>& excluded = {}, double exclude_mm = 0.0) {
  double worst = 0.0;
  for (const auto& b : graph.branches)
    for (const auto& p : b.points) {
      bool skip = false;
      for (const auto& e : excluded) skip = skip || (p - e).norm() < exclude_mm;
      if (!skip) worst = std::max(worst, distance_to_axes(p, axes));
    }
  return worst;
}

TEST(VesselExtraction, StraightTubeGivesOneCentredBranchWithItsRadius) {
  const ImageGeometry g = unit_grid({64, 24, 24});
  const std::vector<AxisSegment> axis{{{8, 11, 12}, {56, 11, 12}}};
  constexpr double radius = 4.0;  // mm
  const VesselExtractionResult r = extract_vessels(draw_tubes(g, axis, radius), given_threshold());
  ASSERT_EQ(r.status, VesselStatus::OK) << r.message;
  EXPECT_EQ(r.branch_count, 1);
  EXPECT_EQ(r.junction_count, 0);
  EXPECT_EQ(r.components_kept, 1);
  // Brief: centreline within 0.5 voxel (here 0.5 mm) of the axis.
  EXPECT_LE(worst_axis_distance(r.graph, axis), 0.5);
  // Radius within 1 voxel, away from the end caps where the inscribed sphere shrinks.
  const auto& b = r.graph.branches.front();
  for (std::size_t i = 0; i < b.points.size(); ++i)
    if (b.points[i].x() > 8 + radius && b.points[i].x() < 56 - radius) {
      EXPECT_NEAR(b.radius[i], radius, 1.0) << "at x = " << b.points[i].x();
    }
  // Length: the axis (48 mm) less at most one radius at each flat end cap.
  EXPECT_GT(r.total_length_mm, 48.0 - 2 * radius);
  EXPECT_LT(r.total_length_mm, 48.0 + 1.0);
}

TEST(VesselExtraction, ObliqueTubeOnAnAnisotropicGridIsCentred) {
  ImageGeometry g;
  g.size = {60, 50, 30};
  g.spacing = {0.8, 0.8, 1.5};
  const std::vector<AxisSegment> axis{{{6, 8, 8}, {42, 32, 36}}};
  const VesselExtractionResult r = extract_vessels(draw_tubes(g, axis, 3.0), given_threshold());
  ASSERT_EQ(r.status, VesselStatus::OK) << r.message;
  EXPECT_EQ(r.branch_count, 1);
  // Half of the coarsest voxel (1.5 mm): a thinned curve lies on voxel centres, and the axis
  // crosses the grid obliquely.
  EXPECT_LE(worst_axis_distance(r.graph, axis), 0.75);
}

TEST(VesselExtraction, YShapedTubeHasOneJunctionAndThreeBranches) {
  const ImageGeometry g = unit_grid({80, 64, 24});
  const Vector3d junction(36, 32, 12);
  const std::vector<AxisSegment> axes{{{6, 32, 12}, junction},
                                      {junction, {72, 54, 12}},
                                      {junction, {72, 10, 12}}};
  constexpr double radius = 3.0;
  const VesselExtractionResult r = extract_vessels(draw_tubes(g, axes, radius), given_threshold());
  ASSERT_EQ(r.status, VesselStatus::OK) << r.message;
  EXPECT_EQ(r.junction_count, 1);
  EXPECT_EQ(r.branch_count, 3);
  EXPECT_EQ(r.endpoint_count, 3);
  // Away from the junction (2 radii), within half a voxel of the axes.
  EXPECT_LE(worst_axis_distance(r.graph, axes, {junction}, 2 * radius), 0.5);
  // The junction node lies near the true branch point (the thinned junction sits where the
  // tubes merge, within about one radius).
  const auto degrees = r.graph.degrees();
  for (std::size_t n = 0; n < degrees.size(); ++n)
    if (degrees[n] == 3) {
      EXPECT_LT((r.graph.nodes[n].position - junction).norm(), radius + 1.0);
    }
}

TEST(VesselExtraction, ShortBumpIsPrunedAsASpur) {
  const ImageGeometry g = unit_grid({64, 28, 28});
  const std::vector<AxisSegment> axis{{{6, 13, 14}, {58, 13, 14}}};
  // A bump on the wall at mid-length: a stub of radius 2 mm whose tip reaches 4 mm beyond the
  // 4 mm wall, so its centreline spur (5 mm measured) is shorter than 2 × the junction radius (≈ 3.1 mm
  // by the distance transform at the junction voxel).
  VolumeF image = draw_tubes(g, axis, 4.0);
  const VolumeF bump = draw_tubes(g, {{{32, 13, 14}, {32, 19, 14}}}, 2.0);
  for (std::size_t v = 0; v < image.data.size(); ++v) image.data[v] = std::max(image.data[v], bump.data[v]);

  VesselExtractionOptions keep_all = given_threshold();
  keep_all.spurs = {0.0, 0.0};
  const VesselExtractionResult unpruned = extract_vessels(image, keep_all);
  ASSERT_EQ(unpruned.status, VesselStatus::OK);
  ASSERT_GE(unpruned.junction_count, 1) << "the bump must create a spur, or the test is void";

  const VesselExtractionResult pruned = extract_vessels(image, given_threshold());
  ASSERT_EQ(pruned.status, VesselStatus::OK);
  EXPECT_GE(pruned.spurs_pruned, 1);
  EXPECT_EQ(pruned.branch_count, 1);
  EXPECT_EQ(pruned.junction_count, 0);
}

TEST(VesselExtraction, EmptyInputsGiveAnEmptyGraphWithAReason) {
  const VesselExtractionResult constant = extract_vessels(VolumeF(unit_grid({8, 8, 8}), 1, 5.0f));
  EXPECT_EQ(constant.status, VesselStatus::EMPTY);
  EXPECT_NE(constant.message.find("fewer than two distinct"), std::string::npos) << constant.message;
  EXPECT_TRUE(constant.graph.branches.empty());

  const VesselExtractionResult dark =
      extract_vessels(VolumeF(unit_grid({8, 8, 8}), 1, 5.0f), given_threshold(10.0));
  EXPECT_EQ(dark.status, VesselStatus::EMPTY);
  EXPECT_NE(dark.message.find("no voxel at or above"), std::string::npos) << dark.message;

  const VesselExtractionResult none = extract_vessels(VolumeF{});
  EXPECT_EQ(none.status, VesselStatus::EMPTY);
  EXPECT_NE(none.message.find("empty volume"), std::string::npos) << none.message;

  // Specks smaller than the minimum component size.
  VolumeF specks(unit_grid({16, 16, 16}), 1, 0.0f);
  specks.at(3, 3, 3) = specks.at(10, 10, 10) = 1000.0f;
  const VesselExtractionResult small = extract_vessels(specks, given_threshold());
  EXPECT_EQ(small.status, VesselStatus::EMPTY);
  EXPECT_EQ(small.components_found, 2);
  EXPECT_NE(small.message.find("no component of at least"), std::string::npos) << small.message;
}

TEST(VesselExtraction, NanVoxelsAreBackgroundAndReported) {
  const ImageGeometry g = unit_grid({48, 20, 20});
  const std::vector<AxisSegment> axis{{{6, 10, 10}, {42, 10, 10}}};
  VolumeF image = draw_tubes(g, axis, 3.0);
  image.at(1, 1, 1) = std::numeric_limits<float>::quiet_NaN();
  image.at(20, 10, 10) = std::numeric_limits<float>::quiet_NaN();  // on the axis
  image.at(2, 3, 4) = std::numeric_limits<float>::infinity();
  const VesselExtractionResult r = extract_vessels(image);  // automatic threshold, too
  ASSERT_EQ(r.status, VesselStatus::OK) << r.message;
  EXPECT_EQ(r.non_finite_voxels, 3);
  EXPECT_EQ(r.branch_count, 1);
}

TEST(VesselExtraction, TissuePeakThresholdSeparatesNoisyBackgroundFromVessels) {
  const ImageGeometry g = unit_grid({64, 32, 32});
  const std::vector<AxisSegment> axis{{{6, 16, 16}, {58, 16, 16}}};
  VolumeF image = draw_tubes(g, axis, 3.5, 900.0f, 0.0f);
  std::mt19937 rng(7);
  std::normal_distribution<float> tissue(200.0f, 25.0f);
  for (float& v : image.data) v += tissue(rng);
  VesselExtractionOptions options;
  options.resample_step_mm = 2.5;
  const VesselExtractionResult r = extract_vessels(image, options);
  ASSERT_EQ(r.status, VesselStatus::OK) << r.message;
  EXPECT_EQ(r.threshold_rule, "tissue peak");
  // tail_fraction 0.02 puts the threshold where a Gaussian peak falls to 2 %: mode + 2.8σ
  // = 270; the ≈ 0.3 % of tissue voxels above it are specks the minimum component size
  // removes (one branch below). Bounds: above mode + 2σ, below the vessels (≈ 1100 ± 75).
  EXPECT_GT(r.threshold, 250.0);
  EXPECT_LT(r.threshold, 800.0);
  EXPECT_EQ(r.branch_count, 1);
  // Resampled at ≤ 2.5 mm steps, equal within the branch.
  const auto& p = r.graph.branches.front().points;
  for (std::size_t i = 1; i < p.size(); ++i) EXPECT_LE((p[i] - p[i - 1]).norm(), 2.5 + 1e-9);
}

TEST(VesselExtraction, SkeletonFormHasOneSegmentPerPolylineStep) {
  const ImageGeometry g = unit_grid({80, 64, 24});
  const Vector3d j(36, 32, 12);
  const VolumeF image = draw_tubes(g, {{{6, 32, 12}, j}, {j, {72, 54, 12}}, {j, {72, 10, 12}}}, 3.0);
  VesselExtractionOptions options;
  options.threshold = 500.0;
  const VesselExtractionResult r = extract_vessels(image, options);
  ASSERT_EQ(r.status, VesselStatus::OK);
  const constraints::Skeleton s = to_skeleton(r.graph);
  std::size_t steps = 0, interior = 0;
  for (const auto& b : r.graph.branches) {
    steps += b.points.size() - 1;
    interior += b.points.size() - 2;
  }
  EXPECT_EQ(s.segments.size(), steps);
  EXPECT_EQ(std::size_t(s.points.rows()), r.graph.nodes.size() + interior);
  EXPECT_EQ(s.radius.size(), s.points.rows());
  EXPECT_TRUE(s.points.allFinite());
}

TEST(VesselExtraction, InvalidOptionsAndVectorVolumesAreErrors) {
  VesselExtractionOptions bad;
  bad.resample_step_mm = -1.0;
  tests::expect_error([&] { extract_vessels(VolumeF(unit_grid({4, 4, 4})), bad); },
                      {"resample_step_mm"});
  tests::expect_error([&] { extract_vessels(VolumeF(unit_grid({4, 4, 4}), 3)); },
                      {"one-component"});
}

TEST(VesselExtraction, A256CubedVolumeWithEightCrossingTubesGivesTheirBranches) {
  // The size of the speed target (256³; timed in bench/, not here). Eight tubes crossing.
  ImageGeometry g = unit_grid({256, 256, 256});
  g.spacing = {0.9, 0.9, 0.9};
  std::vector<AxisSegment> axes;
  for (int t = 0; t < 4; ++t) {
    axes.push_back({{10.0, 30.0 + 45 * t, 40.0 + 30 * t}, {220.0, 40.0 + 40 * t, 60.0 + 30 * t}});
    axes.push_back({{30.0 + 45 * t, 10.0, 100.0}, {50.0 + 40 * t, 220.0, 150.0 - 20 * t}});
  }
  const VolumeF image = draw_tubes(g, axes, 2.5);
  const VesselExtractionResult r = extract_vessels(image);
  ASSERT_EQ(r.status, VesselStatus::OK) << r.message;
  EXPECT_GE(r.branch_count, 8);  // 8 tubes; crossings add junctions and split branches
}

}  // namespace
}  // namespace brainshift::imaging
