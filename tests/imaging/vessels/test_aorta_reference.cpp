// Vessel extraction on a real MR angiogram (VMTK's aorta test data, BSD licence), compared with
// the centerline VMTK computed from the same image (a peer tool's answer).
//
// Coordinate frames. aorta.mha is a MetaImage: DimSize 157 393 34, ElementSpacing
// 0.878906 0.878906 1.50009, Offset −156.445 −24.6094 0, TransformMatrix −1 0 0 0 −1 0 0 0 1.
// Its ITK physical (LPS) point of voxel ijk is Offset + D·diag(spacing)·ijk, which read_volume()
// turns into RAS by negating x and y:  p_RAS = (156.445 + 0.8789 i, 24.6094 + 0.8789 j, 1.5 k).
// VMTK's centerline points (bounds x 210..235, y 101..176, z 21..32) lie inside exactly that
// box, and not inside the LPS one (x −294..−156), nor in origin + spacing·ijk without the
// direction (x −156..−19): VMTK wrote them in this RAS frame (equivalently −Offset + spacing·ijk,
// i.e. VTK's image frame with the origin negated). The test checks this mapping on the image
// itself: the VMTK points must sit in bright lumen voxels in our RAS frame.

#include "synthetic_tubes.hpp"
#include "tests/config.hpp"

#include "core/logger.hpp"
#include "imaging/io/image_io.hpp"
#include "imaging/io/skeleton_io.hpp"
#include "imaging/vessels/vessel_extraction.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <vector>

namespace brainshift::imaging {
namespace {

std::filesystem::path data_dir() { return std::filesystem::path(tests::shared_data_dir) / "vmtk"; }

std::vector<tests::AxisSegment> segments(const VesselGraph& g) {
  std::vector<tests::AxisSegment> s;
  for (const auto& b : g.branches)
    for (std::size_t i = 1; i < b.points.size(); ++i) s.push_back({b.points[i - 1], b.points[i]});
  return s;
}

/// Points of `g`'s polylines, sampled every ≤ 0.25 mm (so distances do not depend on how densely
/// each tool samples its centreline).
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

/// Distances from each point of `from` (dense) to the polylines of `to`.
std::vector<double> distances(const VesselGraph& from, const VesselGraph& to) {
  const auto target = segments(to);
  std::vector<double> d;
  for (const auto& p : dense_points(from)) d.push_back(tests::distance_to_axes(p, target));
  return d;
}

/// Distances to VMTK's centreline from our points that lie inside VMTK's lumen (closer to its
/// centreline than the inscribed-sphere radius there). Our skeleton also holds the other vessels
/// and bright structures of the image, and runs on beyond VMTK's end points; VMTK traced two
/// lines only. The side branches we find leave the aorta through its wall, so their first few
/// mm (up to one aortic radius off VMTK's line) are counted here: they, not the aortic
/// centreline, make the tail of this distribution.
std::vector<double> distances_within_lumen(const VesselGraph& ours, const VesselGraph& vmtk) {
  std::vector<double> d;
  for (const auto& p : dense_points(ours)) {
    double best = 1e300, radius = 0.0;
    for (const auto& b : vmtk.branches)
      for (std::size_t i = 1; i < b.points.size(); ++i) {
        const double e = tests::distance_to_segment(p, b.points[i - 1], b.points[i]);
        if (e < best) {
          best = e;
          radius = std::max(b.radius[i - 1], b.radius[i]);
        }
      }
    if (best <= radius) d.push_back(best);
  }
  return d;
}

struct Stats {
  double mean = 0, p95 = 0, max = 0;
  std::vector<double> values;
  double within_limit_fraction(double limit) const {
    return double(
               std::count_if(values.begin(), values.end(), [&](double v) { return v <= limit; })) /
           double(values.size());
  }
};

Stats stats(std::vector<double> v) {
  Stats s;
  s.values = v;
  std::sort(v.begin(), v.end());
  for (const double x : v) s.mean += x / double(v.size());
  s.p95 = v[std::size_t(0.95 * double(v.size() - 1))];
  s.max = v.back();
  return s;
}

class AortaReference : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!std::filesystem::exists(data_dir() / "aorta.mha") ||
        !std::filesystem::exists(data_dir() / "aorta-centerline.vtp"))
      GTEST_SKIP() << "shared data absent: " << data_dir();
  }
};

TEST_F(AortaReference, VmtkCenterlineLiesInTheLumenInOurRasFrame) {
  const VolumeF image = read_volume(data_dir() / "aorta.mha");
  const VesselGraph vmtk = read_skeleton_vtp(data_dir() / "aorta-centerline.vtp");
  ASSERT_EQ(image.geometry.size, Eigen::Vector3i(157, 393, 34));
  EXPECT_LT((image.geometry.origin - Vector3d(156.445, 24.6094, 0.0)).norm(), 1e-3);
  int inside = 0, total = 0;
  std::vector<float> values;
  for (const auto& b : vmtk.branches)
    for (const auto& p : b.points) {
      const Eigen::Vector3i ijk = image.geometry.world_to_index(p).array().round().cast<int>();
      ++total;
      if (!image.geometry.contains_index(ijk[0], ijk[1], ijk[2])) continue;
      ++inside;
      values.push_back(image.at(ijk[0], ijk[1], ijk[2]));
    }
  EXPECT_EQ(inside, total) << "every VMTK point must fall inside the image in our RAS frame";
  std::sort(values.begin(), values.end());
  const float median = values[values.size() / 2];
  logger().warn("aorta: VMTK centreline intensities: 5th percentile {}, median {}",
                values[values.size() / 20], median);
  EXPECT_GT(median, 1000.0f);
}

TEST_F(AortaReference, SkeletonMatchesVmtkCenterline) {
  const VolumeF image = read_volume(data_dir() / "aorta.mha");
  const VesselGraph vmtk = read_skeleton_vtp(data_dir() / "aorta-centerline.vtp");
  VesselExtractionOptions options;
  const VesselExtractionResult r = extract_vessels(image, options);
  ASSERT_EQ(r.status, VesselStatus::OK) << r.message;
  const Stats vmtk_to_ours = stats(distances(vmtk, r.graph));
  const std::vector<double> inside = distances_within_lumen(r.graph, vmtk);
  ASSERT_FALSE(inside.empty());
  const Stats ours_to_vmtk = stats(inside);
  constexpr double voxel = 0.878906;  // mm, in-plane spacing
  logger().warn("aorta: {}", r.message);
  logger().warn("aorta: VMTK→ours mean {:.2f} p95 {:.2f} max {:.2f} mm, within 2 voxels {:.3f}",
                vmtk_to_ours.mean, vmtk_to_ours.p95, vmtk_to_ours.max,
                vmtk_to_ours.within_limit_fraction(2 * voxel));
  logger().warn(
      "aorta: ours (inside VMTK lumen, {:.0f} mm) → VMTK mean {:.2f} p95 {:.2f} max {:.2f} mm",
      0.25 * double(inside.size()), ours_to_vmtk.mean, ours_to_vmtk.p95, ours_to_vmtk.max);
  // Measured (Release, default options, vessel-contrast threshold 1090): VMTK→ours mean 0.58,
  // p95 1.18, max 2.00 mm, 98.7 % within 2 voxels; ours→VMTK inside its lumen mean 0.99, p95
  // 3.75 mm (side-branch stubs, see distances_within_lumen()). With the former tissue-peak rule:
  // 0.69, 1.65, 2.06 mm, 96.3 %; 1.56, 5.75 mm. Bounds: the brief's aim (mean ≤ 1 voxel) for
  // VMTK→ours, and the former figures plus ≈ 20 % margin (both rules must pass).
  EXPECT_LE(vmtk_to_ours.mean, voxel);
  EXPECT_LE(vmtk_to_ours.p95, 2.0);
  EXPECT_GE(vmtk_to_ours.within_limit_fraction(2 * voxel), 0.93) << "main branches found";
  EXPECT_LE(ours_to_vmtk.mean, 1.9);
  EXPECT_LE(ours_to_vmtk.p95, 7.0);
  // The traced vessels are covered by our skeleton, not by a few stray points: our length
  // inside VMTK's lumen is at least 80 % of VMTK's (two lines sharing their trunk, so VMTK's
  // summed length over-counts the shared part).
  EXPECT_GT(0.25 * double(inside.size()), 0.8 * 0.5 * vmtk.total_length());
}

/// The aorta as a background-suppressed angiogram: every voxel below `level` set to 0, the rest
/// mapped linearly onto 100–254 and rounded to uint8 values, as the TOF file.
VolumeF suppressed_uint8(const VolumeF& image, float level) {
  const float top = *std::max_element(image.data.begin(), image.data.end());
  VolumeF out = image;
  for (float& v : out.data)
    v = v < level ? 0.0F : std::round(100.0F + 154.0F * (v - level) / (top - level));
  return out;
}

TEST_F(AortaReference, BackgroundSuppressedUint8AortaGivesTheSameSkeleton) {
  const VolumeF image = read_volume(data_dir() / "aorta.mha");
  const VesselGraph vmtk = read_skeleton_vtp(data_dir() / "aorta-centerline.vtp");
  const VesselExtractionResult original = extract_vessels(image);
  ASSERT_EQ(original.status, VesselStatus::OK) << original.message;
  // The level is the one the data gave on the original (its vessel threshold): the scanner's
  // suppression removes the background and keeps the vessels.
  const VolumeF suppressed = suppressed_uint8(image, float(original.threshold));
  const auto zero = std::count(suppressed.data.begin(), suppressed.data.end(), 0.0F);
  logger().warn("suppressed aorta: level {:.0f}, {:.1f} % of voxels 0", original.threshold,
                100.0 * double(zero) / double(suppressed.data.size()));
  ASSERT_GE(double(zero) / double(suppressed.data.size()), 0.95);
  const VesselExtractionResult r = extract_vessels(suppressed);
  ASSERT_EQ(r.status, VesselStatus::OK) << r.message;
  logger().warn("suppressed aorta: {}", r.message);
  // The threshold lies inside the kept range (above the zeroed background, at most the maximum).
  EXPECT_GT(r.threshold, 0.0);
  EXPECT_LE(r.threshold, 254.0);
  // Same skeleton: both ways, within the original's lumen scale.
  const Stats to_original = stats(distances(r.graph, original.graph));
  const Stats from_original = stats(distances(original.graph, r.graph));
  const Stats vmtk_to_ours = stats(distances(vmtk, r.graph));
  constexpr double voxel = 0.878906;  // mm, in-plane spacing
  logger().warn(
      "suppressed aorta: → original mean {:.2f} p95 {:.2f} mm; original → it mean {:.2f} p95 "
      "{:.2f} mm; "
      "VMTK → it mean {:.2f} p95 {:.2f} mm; lengths {:.0f} / {:.0f} mm",
      to_original.mean, to_original.p95, from_original.mean, from_original.p95, vmtk_to_ours.mean,
      vmtk_to_ours.p95, r.total_length_mm, original.total_length_mm);
  // Measured (Release): → original mean 0.61, p95 2.61 mm; original → it mean 0.57, p95 2.17 mm;
  // lengths 845 / 837 mm. The differences are junction corners and branch ends that move by a
  // voxel or two (the pre-filter sees a zero background instead of tissue). Bounds: mean within
  // a voxel, p95 within 4 voxels, length within 10 %.
  EXPECT_LE(to_original.mean, voxel);
  EXPECT_LE(to_original.p95, 4.0 * voxel);
  EXPECT_LE(from_original.mean, voxel);
  EXPECT_LE(from_original.p95, 4.0 * voxel);
  EXPECT_NEAR(r.total_length_mm, original.total_length_mm, 0.1 * original.total_length_mm);
  // VMTK's traced vessels are found as in the original test.
  EXPECT_LE(vmtk_to_ours.mean, voxel);
  EXPECT_LE(vmtk_to_ours.p95, 2.0);
}

}  // namespace
}  // namespace brainshift::imaging
