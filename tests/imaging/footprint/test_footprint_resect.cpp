// The probe footprint on real freehand B-mode (issue 13 items 5 and 6): the 17 RESECT volumes
// in ../shared/data/resect (float32, ≈ 0.5 mm, oblique grids whose k axis is not the beam, 0
// outside the swept sector; the probe sat on the dura at the narrow end of each sector).
// Label `real`; skips when the folder is absent.
#include "tests/config.hpp"

#include "imaging/footprint/freehand_footprint.hpp"
#include "imaging/io/image_io.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <vector>

namespace brainshift::imaging {
namespace {

const std::vector<int> kCases = {1, 2, 3, 4, 5, 6, 8, 12, 14, 15, 16, 18, 23, 24, 25, 26, 27};

std::filesystem::path resect_dir() {
  return std::filesystem::path(tests::shared_data_dir) / "resect";
}

/// What makes a footprint plausible (the issue's "at the near-field edge of the swept region,
/// normals into the tissue", the brief's "a probe face is ~10-40 mm wide"), checked here
/// independently of the library's own warnings:
constexpr double kMaxEdgeDistanceMm = 4.0;  // every point within 4 mm of the swept region's
                                            // edge, going back along the beam (band ≈ 1-3 mm in)
constexpr double kNearEndShare = 0.2;       // … and in the first 20 % of the region's depth
constexpr double kMinWidthMm = 10.0;        // patch width: a probe face is 10–40 mm wide,
constexpr double kMaxWidthMm = 45.0;        // + one 5 mm margin for the sector's slight widening
constexpr double kMinBeamCos = 0.5;         // normals within 60° of the beam …
// … and towards the bulk: n · (centroid − p) > 0, with the centroid of the swept voxels.

struct Swept {
  Vector3d centroid = Vector3d::Zero();
  double t_min = 0.0;  // 0.5th percentile of the swept voxels' depth along the beam
  double t_max = 0.0;  // 99.5th percentile
};

Swept swept_region(const VolumeF& v, const Vector3d& beam) {
  Swept s;
  std::vector<double> t;
  const auto& g = v.geometry;
  for (int k = 0; k < g.size[2]; ++k)
    for (int j = 0; j < g.size[1]; ++j)
      for (int i = 0; i < g.size[0]; ++i) {
        const float x = v.at(i, j, k);
        if (!(std::isfinite(x) && x != 0.0F)) continue;
        const Vector3d p = g.index_to_world(Vector3d(i, j, k));
        s.centroid += p;
        t.push_back(beam.dot(p));
      }
  s.centroid /= double(t.size());
  std::sort(t.begin(), t.end());
  s.t_min = t[t.size() / 200];
  s.t_max = t[t.size() - 1 - t.size() / 200];
  return s;
}

/// Depth of p below the first non-swept voxel met going back along the beam (0.25 mm steps).
double edge_distance(const VolumeF& v, const Vector3d& p, const Vector3d& beam) {
  double s = 0.0;
  for (; s < 50.0; s += 0.25) {
    const Vector3d c = v.geometry.world_to_index(p - (s + 0.25) * beam);
    const int i = int(std::lround(c.x())), j = int(std::lround(c.y())), k = int(std::lround(c.z()));
    if (!v.geometry.contains_index(i, j, k)) break;
    const float x = v.at(i, j, k);
    if (!(std::isfinite(x) && x != 0.0F)) break;
  }
  return s;
}

/// The same volume with its near-field band cut away: every swept voxel within 4 mm of the
/// swept region's edge going back along `beam` set to 0 (outside). What is left is tissue
/// whose near end has no contact band.
VolumeF without_band(const VolumeF& v, const Vector3d& beam) {
  VolumeF out = v;
  const auto& g = v.geometry;
  for (int k = 0; k < g.size[2]; ++k)
    for (int j = 0; j < g.size[1]; ++j)
      for (int i = 0; i < g.size[0]; ++i)
        if (v.at(i, j, k) != 0.0F &&
            edge_distance(v, g.index_to_world(Vector3d(i, j, k)), beam) < 4.0)
          out.at(i, j, k) = 0.0F;
  return out;
}

TEST(FootprintResect, PlausibleFootprintOnAtLeast13Of17Volumes) {
  if (!std::filesystem::is_directory(resect_dir()))
    GTEST_SKIP() << "real data absent: " << resect_dir() << " (RESECT B-mode volumes)";
  int plausible = 0;
  int without_band_found = 0;
  std::printf(
      "[ measured ] case  points  width  elev  contrast  fan_fit  edge_max  near_share  ok | "
      "no-band contrast\n");
  for (const int c : kCases) {
    const auto file = resect_dir() / ("Case" + std::to_string(c) + ".nii.gz");
    ASSERT_TRUE(std::filesystem::exists(file)) << file;
    const VolumeF v = read_volume(file);
    const FreehandFootprint r = extract_freehand_footprint(v);
    const Vector3d beam = r.beam.direction;
    bool ok = r.footprint.status == FootprintStatus::OK && r.width_mm >= kMinWidthMm &&
              r.width_mm <= kMaxWidthMm;
    double edge_max = 0.0, share_max = 0.0;
    if (r.footprint.status == FootprintStatus::OK) {
      const Swept s = swept_region(v, beam);
      for (Eigen::Index p = 0; p < r.footprint.points.rows(); ++p) {
        const Vector3d x = r.footprint.points.row(p).transpose();
        const Vector3d n = r.footprint.normals.row(p).transpose();
        const double edge = edge_distance(v, x, beam);
        const double share = (beam.dot(x) - s.t_min) / (s.t_max - s.t_min);
        edge_max = std::max(edge_max, edge);
        share_max = std::max(share_max, share);
        ok = ok && edge <= kMaxEdgeDistanceMm && share <= kNearEndShare &&
             n.dot(beam) >= kMinBeamCos && n.dot(s.centroid - x) > 0.0;
      }
    }
    plausible += ok ? 1 : 0;
    // The same volume without its band, along the beam found: no footprint expected.
    const FreehandFootprint nb = extract_freehand_footprint(without_band(v, beam), beam);
    without_band_found += nb.footprint.status == FootprintStatus::OK ? 1 : 0;
    std::printf("[ measured ] %4d  %6td  %5.1f  %4.1f  %8.2f  %7.3f  %8.2f  %10.3f  %s | %s %.2f\n",
                c, r.footprint.points.rows(), r.width_mm, r.elevation_mm, r.footprint.contrast,
                r.beam.fan_fit, edge_max, share_max, ok ? "yes" : "NO ",
                nb.footprint.status == FootprintStatus::OK ? "found" : "none ",
                nb.footprint.contrast);
    if (!ok) std::printf("[ measured ]       %s\n", r.footprint.message.c_str());
  }
  std::printf(
      "[ measured ] plausible footprints on %d of %zu volumes; %d footprint(s) without the band\n",
      plausible, kCases.size(), without_band_found);
  // The issue: "a plausible footprint on at least 13 of 17".
  EXPECT_GE(plausible, 13);
  // With the band cut away, the contrast rule must refuse nearly all: at most 3 of 17 slip
  // through (measured: 2; a broad band's tail or a bright structure under the new near end can
  // still look like a band).
  EXPECT_LE(without_band_found, 3);
}

}  // namespace
}  // namespace brainshift::imaging
