// Vessel extraction on realistic stand-ins for the real angiograms of issue 13 that are not in
// the shared data (angiogram_standins.hpp): a background-suppressed uint8 TOF, a raw int16 TOF
// with a bright fat/skin shell, and a noisy angiogram with coil bias and correlated noise. Each
// must find the vessels: total length near the truth, the skeleton near the true centrelines,
// the true centrelines covered, and a threshold above the noise and below the image maximum.

#include "angiogram_standins.hpp"

#include "core/logger.hpp"
#include "imaging/vessels/vessel_extraction.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

namespace brainshift::imaging {
namespace {

using tests::Angiogram;

/// Points every ≤ 0.25 mm along the branches of `g` (so the measures do not depend on sampling).
std::vector<Vector3d> dense_points(const VesselGraph& g) {
  std::vector<Vector3d> out;
  for (const auto& b : g.branches)
    for (std::size_t i = 1; i < b.points.size(); ++i) {
      const int n = std::max(1, int(std::ceil((b.points[i] - b.points[i - 1]).norm() / 0.25)));
      for (int s = (i == 1 ? 0 : 1); s <= n; ++s)
        out.push_back(b.points[i - 1] + (b.points[i] - b.points[i - 1]) * double(s) / n);
    }
  return out;
}

/// Share of the skeleton (by length) within `tolerance` mm of the true centrelines.
double share_near_truth(const VesselGraph& g, const Angiogram& a, double tolerance) {
  const auto axes = a.axes();
  const auto points = dense_points(g);
  const auto near = std::count_if(points.begin(), points.end(), [&](const Vector3d& p) {
    return tests::distance_to_axes(p, axes) <= tolerance;
  });
  return points.empty() ? 0.0 : double(near) / double(points.size());
}

/// Share of the true centrelines (by length) within `tolerance` mm of the skeleton.
double share_of_truth_found(const VesselGraph& g, const Angiogram& a, double tolerance) {
  std::vector<tests::AxisSegment> ours;
  for (const auto& b : g.branches)
    for (std::size_t i = 1; i < b.points.size(); ++i)
      ours.push_back({b.points[i - 1], b.points[i]});
  std::size_t found = 0, total = 0;
  for (const auto& v : a.vessels) {
    const int n = std::max(1, int(std::ceil((v.b - v.a).norm() / 0.25)));
    for (int s = 0; s <= n; ++s) {
      ++total;
      found +=
          tests::distance_to_axes(v.a + (v.b - v.a) * double(s) / n, ours) <= tolerance ? 1 : 0;
    }
  }
  return double(found) / double(total);
}

float image_max(const VolumeF& v) { return *std::max_element(v.data.begin(), v.data.end()); }

void log_result(const char* name, const VesselExtractionResult& r, const Angiogram& a) {
  logger().warn("{}: {} | truth {:.0f} mm | near truth (1 mm) {:.3f}, truth found (1.5 mm) {:.3f}",
                name, r.message, a.length(), share_near_truth(r.graph, a, 1.0),
                share_of_truth_found(r.graph, a, 1.5));
}

TEST(AngiogramStandIns, BackgroundSuppressedUint8TofFindsTheCircleOfWillis) {
  const Angiogram a = tests::suppressed_tof();
  std::int64_t zero = std::count(a.image.data.begin(), a.image.data.end(), 0.0F);
  // The issue's file: 99 % of voxels 0, vessels 100–254 (the stand-in must be like it).
  ASSERT_GE(double(zero) / double(a.image.data.size()), 0.99);
  const VesselExtractionResult r = extract_vessels(a.image);
  ASSERT_EQ(r.status, VesselStatus::OK) << r.message;
  log_result("suppressed TOF", r, a);
  EXPECT_TRUE(r.background_suppressed) << r.message;
  // The issue's failure: a threshold of 483 above the maximum 254. Now it lies above the
  // suppressed background (0) and below the vessels' centre level (≈ 180 after the pre-filter;
  // the threshold is in pre-filtered units, where a vessel's wall falls below 100).
  EXPECT_GT(r.threshold, 50.0);
  EXPECT_LT(r.threshold, r.vessel_level);
  EXPECT_LT(r.threshold, image_max(a.image));
  // Length within [0.8, 1.15] × the truth (≈ 277 mm): branch ends lose up to a radius each,
  // the ring's junctions round their corners; no noise makes it longer.
  EXPECT_GT(r.total_length_mm, 0.8 * a.length());
  EXPECT_LT(r.total_length_mm, 1.15 * a.length());
  // ≥ 90 % of the skeleton within 1 mm (2 voxels) of the true centrelines (junction corners
  // make the rest), and ≥ 90 % of the true centrelines within 1.5 mm of it (ring and branches
  // found).
  EXPECT_GE(share_near_truth(r.graph, a, 1.0), 0.9);
  EXPECT_GE(share_of_truth_found(r.graph, a, 1.5), 0.9);
  // 19 pieces meeting at 8 junctions: the graph has between 15 and 40 branches (spurs pruned,
  // a few junctions split in two).
  EXPECT_GE(r.branch_count, 15);
  EXPECT_LE(r.branch_count, 40);
}

TEST(AngiogramStandIns, RawInt16TofIgnoresTheFatAndSkinShell) {
  const Angiogram a = tests::raw_tof_with_fat();
  const VesselExtractionResult r = extract_vessels(a.image);
  ASSERT_EQ(r.status, VesselStatus::OK) << r.message;
  log_result("raw TOF", r, a);
  // Above the brain tissue (250 + 20 noise: 5 σ = 350) and below the vessels (650 at their wall).
  EXPECT_GT(r.threshold, 350.0);
  EXPECT_LT(r.threshold, 650.0);
  EXPECT_LT(r.threshold, image_max(a.image));
  // The shell (≈ 100 times the vessels' volume) is not tubular and goes.
  EXPECT_GE(r.components_not_tubular, 1);
  EXPECT_GT(r.total_length_mm, 0.8 * a.length());
  EXPECT_LT(r.total_length_mm, 1.15 * a.length());
  EXPECT_GE(share_near_truth(r.graph, a, 1.0), 0.9);
  EXPECT_GE(share_of_truth_found(r.graph, a, 1.5), 0.9);
}

TEST(AngiogramStandIns, NoisyAngiogramGivesItsEightTubesNotMetresOfNoise) {
  const Angiogram a = tests::noisy_angiogram();
  ASSERT_NEAR(a.length(), 300.0, 1e-6);
  const VesselExtractionResult r = extract_vessels(a.image);
  ASSERT_EQ(r.status, VesselStatus::OK) << r.message;
  log_result("noisy angiogram", r, a);
  EXPECT_LT(r.threshold, image_max(a.image));
  // Above the tissue (200 at the field's centre) plus 3 σ of its noise (≈ 20 after the
  // pre-filter): the former rule below put it at 177, inside the tissue.
  EXPECT_GT(r.threshold, 260.0);
  // Length within [0.7, 1.3] × the truth (crossing tubes merge, ends shorten), and 8 tubes
  // give 8 to 30 branches (crossings split them).
  EXPECT_GT(r.total_length_mm, 0.7 * a.length());
  EXPECT_LT(r.total_length_mm, 1.3 * a.length());
  EXPECT_GE(r.branch_count, 8);
  EXPECT_LE(r.branch_count, 30);
  EXPECT_GE(share_near_truth(r.graph, a, 1.0), 0.85);
  EXPECT_GE(share_of_truth_found(r.graph, a, 1.5), 0.85);

  // Not void: the former rule (tissue peak raised to the raw-image noise floor), with prepare's
  // MRA setting (no pre-filter), lands in the noise here and reports metres of "vessels".
  VesselExtractionOptions former;
  former.threshold_method = ThresholdMethod::TISSUE_PEAK;
  former.prefilter_sigma_mm = 0.0;
  const VesselExtractionResult old = extract_vessels(a.image, former);
  logger().warn("noisy angiogram, former rule: {}", old.message);
  EXPECT_GT(old.total_length_mm, 10.0 * a.length()) << old.message;
}

TEST(AngiogramStandIns, WeakContrastIsExtractedWithAWarning) {
  // A 56 mm tube of radius 3 mm, 100 above tissue 200 with white noise σ 40 (after the 0.6 mm
  // pre-filter ≈ 14): the half-maximum (≈ 250) lies within 4 σ̂ of the tissue, so the threshold
  // is raised to the noise floor and the result says the contrast is weak.
  const auto tube = [](float contrast) {
    ImageGeometry g;
    g.size = {72, 48, 48};
    VolumeF image =
        tests::draw_tubes(g, {{{8, 24, 24}, {64, 24, 24}}}, 3.0, 200.0F + contrast, 200.0F);
    std::mt19937 rng(41);
    std::normal_distribution<float> noise(0.0F, 40.0F);
    for (float& v : image.data) v += noise(rng);
    return image;
  };
  const VesselExtractionResult weak = extract_vessels(tube(100.0F));
  ASSERT_EQ(weak.status, VesselStatus::OK) << weak.message;
  EXPECT_EQ(weak.threshold_rule, "noise floor");
  ASSERT_FALSE(weak.warnings.empty());
  EXPECT_NE(weak.warnings.front().find("weak vessel contrast"), std::string::npos)
      << weak.warnings.front();
  EXPECT_EQ(weak.branch_count, 1);
  EXPECT_GT(weak.total_length_mm, 56.0 - 2 * 3.0);  // the axis less a radius at each end
  // With 140 above the tissue the half-maximum clears the noise floor: no warning.
  const VesselExtractionResult clear = extract_vessels(tube(140.0F));
  ASSERT_EQ(clear.status, VesselStatus::OK) << clear.message;
  EXPECT_EQ(clear.threshold_rule, "vessel contrast");
  EXPECT_TRUE(clear.warnings.empty());
}

TEST(AngiogramStandIns, PureNoiseHasNoVessels) {
  // Tissue with correlated noise and no vessel: EMPTY, with the reason.
  ImageGeometry g;
  g.size = {100, 100, 60};
  g.spacing = {0.5, 0.5, 0.5};
  VolumeF image = tests::correlated_noise(g, 30.0, 0.8, 31);
  for (float& v : image.data) v = std::max(0.0F, v + 200.0F);
  const VesselExtractionResult r = extract_vessels(image);
  EXPECT_EQ(r.status, VesselStatus::EMPTY) << r.message;
}

}  // namespace
}  // namespace brainshift::imaging
