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

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <vector>

#include "tests/config.hpp"
#include "core/logger.hpp"
#include "imaging/io/image_io.hpp"
#include "imaging/io/skeleton_io.hpp"
#include "imaging/vessels/vessel_extraction.hpp"
#include "synthetic_tubes.hpp"

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
    return double(std::count_if(values.begin(), values.end(), [&](double v) { return v <= limit; })) /
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
  logger().warn("aorta: ours (inside VMTK lumen, {:.0f} mm) → VMTK mean {:.2f} p95 {:.2f} max {:.2f} mm",
                0.25 * double(inside.size()), ours_to_vmtk.mean, ours_to_vmtk.p95, ours_to_vmtk.max);
  // Measured (Release, default options): VMTK→ours mean 0.69, p95 1.65, max 2.06 mm, 96.3 %
  // within 2 voxels; ours→VMTK inside its lumen mean 1.56, p95 5.75 mm (side-branch stubs, see
  // distances_within_lumen()). Bounds: the brief's aim (mean ≤ 1 voxel) for VMTK→ours, and the
  // measured values plus ≈ 20 % margin.
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

}  // namespace
}  // namespace brainshift::imaging
