#include "expect_error.hpp"
#include "synthetic_tubes.hpp"

#include "core/logger.hpp"
#include "imaging/vessels/vessel_extraction.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

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
  const std::vector<AxisSegment> axes{
      {{6, 32, 12}, junction}, {junction, {72, 54, 12}}, {junction, {72, 10, 12}}};
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
  // 4 mm wall, so its centreline spur (5 mm measured) is shorter than 2 × the junction radius
  // (≈ 3.1 mm by the distance transform at the junction voxel).
  VolumeF image = draw_tubes(g, axis, 4.0);
  const VolumeF bump = draw_tubes(g, {{{32, 13, 14}, {32, 19, 14}}}, 2.0);
  for (std::size_t v = 0; v < image.data.size(); ++v)
    image.data[v] = std::max(image.data[v], bump.data[v]);

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
  EXPECT_NE(constant.message.find("no tubular structure"), std::string::npos) << constant.message;
  VesselExtractionOptions histogram;
  histogram.threshold_method = ThresholdMethod::OTSU;
  const VesselExtractionResult flat =
      extract_vessels(VolumeF(unit_grid({8, 8, 8}), 1, 5.0f), histogram);
  EXPECT_NE(flat.message.find("fewer than two distinct"), std::string::npos) << flat.message;
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
  VesselExtractionOptions unfiltered = given_threshold();
  unfiltered.prefilter_sigma_mm = 0.0;  // the pre-filter would spread each speck below 500
  const VesselExtractionResult small = extract_vessels(specks, unfiltered);
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
  options.threshold_method = ThresholdMethod::TISSUE_PEAK;  // the former rule, still available
  const VesselExtractionResult r = extract_vessels(image, options);
  ASSERT_EQ(r.status, VesselStatus::OK) << r.message;
  // The vessel-contrast rule (the default) puts it at the half-maximum: (200 + 1100) / 2 ± noise.
  const VesselExtractionResult c = extract_vessels(image);
  ASSERT_EQ(c.status, VesselStatus::OK) << c.message;
  EXPECT_EQ(c.threshold_rule, "vessel contrast");
  EXPECT_NEAR(c.threshold, 650.0, 100.0)
      << c.message;  // vessel level taken from voxels near the axis
  EXPECT_EQ(c.branch_count, 1);
  // The noise floor (median + 8 σ̂ of the tissue, σ̂ scaled by the pre-filter's white-noise
  // gain ≈ 0.3) and the tissue-peak rule land close together; either may win.
  EXPECT_TRUE(r.threshold_rule == "tissue peak" || r.threshold_rule == "noise floor")
      << r.threshold_rule;
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
  const VolumeF image =
      draw_tubes(g, {{{6, 32, 12}, j}, {j, {72, 54, 12}}, {j, {72, 10, 12}}}, 3.0);
  VesselExtractionOptions options;
  options.threshold = 500.0;
  const VesselExtractionResult r = extract_vessels(image, options);
  ASSERT_EQ(r.status, VesselStatus::OK);
  const core::Skeleton s = to_skeleton(r.graph);
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
  tests::expect_error(
      [&] {
        extract_vessels(VolumeF(unit_grid({4, 4, 4})), bad);
      },
      {"resample_step_mm"});
  tests::expect_error(
      [&] {
        extract_vessels(VolumeF(unit_grid({4, 4, 4}), 3));
      },
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

/// A power-Doppler-like volume (0.8 mm voxels, values in [0, 255]) of tubes of the given radius:
/// 255 × (tube indicator) × gamma speckle of the given shape + |N(0, clutter)|, plus `blobs`
/// spurious Gaussian flow blobs. Like an ultrasound field of view, only the box [0, 88] × [0, 72]
/// × [0, 48] mm carries signal; the rest of the grid is exactly 0.
VolumeF doppler_like(const std::vector<AxisSegment>& axes, double radius, double speckle_shape,
                     double clutter, int blobs, std::uint32_t seed) {
  ImageGeometry g;
  g.size = {140, 120, 80};
  g.spacing = {0.8, 0.8, 0.8};
  VolumeF image = draw_tubes(g, axes, radius, 1.0f, 0.0f);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int b = 0; b < blobs; ++b) {
    const Vector3d c(u(rng) * 88, u(rng) * 72, u(rng) * 48);
    const double sigma = 0.8 + 1.2 * u(rng), amplitude = 0.4 + 0.5 * u(rng);
    for (int k = 0; k < g.size[2]; ++k)
      for (int j = 0; j < g.size[1]; ++j)
        for (int i = 0; i < g.size[0]; ++i) {
          const double d2 = (g.index_to_world(Vector3d(i, j, k)) - c).squaredNorm();
          if (d2 < 9 * sigma * sigma)
            image.at(i, j, k) = std::max(image.at(i, j, k),
                                         float(amplitude * std::exp(-0.5 * d2 / (sigma * sigma))));
        }
  }
  std::gamma_distribution<double> speckle(speckle_shape, 1.0 / speckle_shape);
  std::normal_distribution<double> noise(0.0, clutter);
  for (float& v : image.data)
    v = float(std::clamp(255.0 * v * speckle(rng) + std::abs(noise(rng)), 0.0, 255.0));
  for (int k = 0; k < g.size[2]; ++k)
    for (int j = 0; j < g.size[1]; ++j)
      for (int i = 0; i < g.size[0]; ++i)
        if ((g.index_to_world(Vector3d(i, j, k)).array() > Eigen::Array3d(88, 72, 48)).any())
          image.at(i, j, k) = 0.0f;
  return image;
}

/// Fraction of the graph's points within `tolerance` mm of the other graph's polylines.
double fraction_near(const VesselGraph& graph, const VesselGraph& other, double tolerance) {
  std::vector<AxisSegment> segments;
  for (const auto& b : other.branches)
    for (std::size_t i = 1; i < b.points.size(); ++i)
      segments.push_back({b.points[i - 1], b.points[i]});
  std::size_t near = 0, total = 0;
  for (const auto& b : graph.branches)
    for (const auto& p : b.points) {
      ++total;
      near += distance_to_axes(p, segments) <= tolerance ? 1 : 0;
    }
  return total == 0 ? 0.0 : double(near) / double(total);
}

TEST(VesselExtraction, NoisyDopplerGivesTheCleanCentrelines) {
  // A branching tree and a separate vessel, ≈ 185 mm of axis, radius 2 mm (a Doppler's blooming
  // of a 1–1.5 mm vessel). Clean: speckle shape 4, clutter σ 3 (the phantom's standard Doppler).
  // Noisy: speckle shape 1.5, clutter σ 12, 25 blobs, two gaps (the noisy_doppler case).
  const Vector3d j1(40, 36, 24), j2(62, 30, 26);
  const std::vector<AxisSegment> tree{{{8, 40, 22}, j1},  {j1, j2},
                                      {j2, {84, 14, 30}}, {j2, {82, 50, 20}},
                                      {j1, {30, 64, 30}}, {{20, 10, 40}, {80, 66, 40}}};
  std::vector<AxisSegment> with_gaps = tree;
  with_gaps[2] = {j2, j2 + 0.5 * (Vector3d(84, 14, 30) - j2)};  // the far half missing
  with_gaps[5] = {{20, 10, 40}, {44, 32.4, 40}};                // and a 20 mm stretch
  with_gaps.push_back({{62, 47.2, 40}, {80, 66, 40}});
  const VolumeF clean_image = doppler_like(tree, 2.0, 4.0, 3.0, 4, 11);
  const VolumeF noisy_image = doppler_like(with_gaps, 2.0, 1.5, 12.0, 25, 12);

  const VesselExtractionResult clean = extract_vessels(clean_image);
  const VesselExtractionResult noisy = extract_vessels(noisy_image);
  ASSERT_EQ(clean.status, VesselStatus::OK) << clean.message;
  ASSERT_EQ(noisy.status, VesselStatus::OK) << noisy.message;
  // The clean extraction follows the axes: ≥ 90 % of its points within 2 mm (the radius; a
  // junction rounds its corner), and its length within [0.7, 1.2] × the axes' (ends lose up to a
  // radius each, speckle may leave a stub).
  double axis_length = 0.0;
  for (const auto& s : tree) axis_length += (s.b - s.a).norm();
  std::size_t near_axes = 0, points = 0;
  for (const auto& b : clean.graph.branches)
    for (const auto& p : b.points) {
      ++points;
      near_axes += distance_to_axes(p, tree) <= 2.0 ? 1 : 0;
    }
  EXPECT_GE(double(near_axes), 0.9 * double(points));
  EXPECT_GT(clean.total_length_mm, 0.7 * axis_length);
  EXPECT_LT(clean.total_length_mm, 1.2 * axis_length);
  // The noisy one: dropout removes ≈ 40 mm (≈ 20 %), so its length lies within [0.5, 1.5] × the
  // clean one's (the brief: same order, not thousands of mm of noise floor), and ≥ 80 % of its
  // points lie within 2 mm (one vessel radius) of the clean centrelines.
  EXPECT_GT(noisy.total_length_mm, 0.5 * clean.total_length_mm) << noisy.message;
  EXPECT_LT(noisy.total_length_mm, 1.5 * clean.total_length_mm) << noisy.message;
  EXPECT_GE(fraction_near(noisy.graph, clean.graph, 2.0), 0.8) << noisy.message;

  // Not void: without the pre-filter, noise floor and shape rule (the former pipeline), the
  // noise floor passes the threshold and the "vessels" are many times longer.
  VesselExtractionOptions former;
  former.threshold_method = ThresholdMethod::TISSUE_PEAK;
  former.prefilter_sigma_mm = 0.0;
  former.noise_floor_k = 0.0;
  former.min_piece_length_mm = 0.0;
  former.min_piece_elongation = 0.0;
  const VesselExtractionResult old = extract_vessels(noisy_image, former);
  EXPECT_GT(old.total_length_mm, 5.0 * clean.total_length_mm) << old.message;
}

}  // namespace
}  // namespace brainshift::imaging
