// Volume reconstruction from a PLUS sequence file (issue 35): frames cut from a volume along a
// tracked path are written as a PLUS sequence by a writer here that follows PLUS's published
// header format (not by the reader's code), reconstructed, and compared with the volume they
// were cut from: on a smooth synthetic volume and on a real intra-operative B-mode volume
// (RESECT Case1, ../shared/data).
#include "expect_error.hpp"
#include "plus_sweep.hpp"
#include "temp_folder.hpp"
#include "tests/config.hpp"

#include "imaging/io/image_io.hpp"
#include "imaging/io/plus_sequence.hpp"
#include "imaging/reconstruction/volume_reconstruction.hpp"

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

namespace brainshift::imaging {
namespace {

namespace fs = std::filesystem;
using Eigen::Matrix4d;
using tests::cut_sweep;
using tests::matrix_text;
using tests::sample;
using tests::Sweep;
using tests::write_plus_sequence;

/// Pearson correlation of the reconstruction with `truth` sampled at its voxel centres shifted
/// by `shift` (mm), over the voxels of the sweep (coverage 1 or 2) at least one voxel inside it.
double correlation(const VolumeF& rec, const LabelVolume& coverage, const VolumeF& truth,
                   const Vector3d& shift) {
  double sx = 0, sy = 0, sxx = 0, syy = 0, sxy = 0;
  long n = 0;
  const ImageGeometry& g = rec.geometry;
  for (int k = 1; k + 1 < g.size[2]; ++k)
    for (int j = 1; j + 1 < g.size[1]; ++j)
      for (int i = 1; i + 1 < g.size[0]; ++i) {
        bool inside = true;
        for (int d = 0; d < 27 && inside; ++d)
          inside = coverage.at(i + d % 3 - 1, j + (d / 3) % 3 - 1, k + d / 9 - 1) != 0;
        if (!inside) continue;
        const double y = sample(truth, g.index_to_world(Vector3d(i, j, k)) + shift);
        if (!std::isfinite(y)) continue;
        const double x = rec.at(i, j, k);
        sx += x, sy += y, sxx += x * x, syy += y * y, sxy += x * y;
        ++n;
      }
  EXPECT_GT(n, 1000) << "too few voxels inside the sweep";
  const double cov = sxy / double(n) - sx * sy / double(n * n);
  return cov / std::sqrt((sxx / double(n) - sx * sx / double(n * n)) *
                         (syy / double(n) - sy * sy / double(n * n)));
}

/// The acceptance of issue 35 on `truth`: correlation ≥ 0.95 inside the sweep and the peak of
/// the correlation (a parabola through the shifts −1, 0, +1 voxel along each axis) within half
/// a voxel of no shift. Returns the correlation.
double check_round_trip(const VolumeF& truth, double pixel_mm, double step_mm, int frames,
                        const std::string& orientation) {
  const tests::TempFolder dir;
  const std::vector<int> invalid = {3, 17, 18};
  const Sweep s = cut_sweep(truth, pixel_mm, step_mm, frames, invalid);
  write_plus_sequence(dir / "sweep.seq.mha", s, orientation);
  {
    std::ofstream c(dir / "ImageToProbe.txt");
    c << matrix_text(s.calibration) << '\n';
  }
  const double spacing = truth.geometry.spacing.minCoeff();
  SequenceReconstructionOptions o;
  o.calibration = read_matrix_file(dir / "ImageToProbe.txt");
  o.spacing_mm = spacing;
  ReconstructionReport rep;
  LabelVolume coverage;
  const VolumeF rec = reconstruct_sequence_file(dir / "sweep.seq.mha", o, &rep, &coverage);
  EXPECT_EQ(rep.frames, frames);
  EXPECT_EQ(rep.frames_skipped, int(invalid.size())) << "frames with an INVALID status";
  EXPECT_GT(rep.voxels_filled, 0) << "frames " << step_mm << " mm apart leave gaps to fill";
  const double c0 = correlation(rec, coverage, truth, Vector3d::Zero());
  EXPECT_GE(c0, 0.95);
  std::cout << "[ measured ] " << rep.frames_placed << " frames, " << rep.voxels_hit
            << " voxels reached, " << rep.voxels_filled << " filled (radius " << rep.fill_radius
            << "); correlation " << c0 << "; peak shift (voxels)";
  for (int a = 0; a < 3; ++a) {
    Vector3d e = Vector3d::Zero();
    e[a] = spacing;
    const double cm = correlation(rec, coverage, truth, -e),
                 cp = correlation(rec, coverage, truth, e);
    const double curvature = cm - 2 * c0 + cp;
    EXPECT_LT(curvature, 0) << "no correlation peak along axis " << a;
    if (curvature >= 0) continue;
    const double peak = 0.5 * (cm - cp) / curvature;  // voxels
    EXPECT_LE(std::abs(peak), 0.5) << "axis " << a << ": shifted by " << peak << " voxel";
    std::cout << ' ' << peak;
  }
  std::cout << '\n';
  return c0;
}

/// A smooth volume: Gaussian blobs of 1.5–4 mm on a 0.5 mm grid, values 0–255.
VolumeF blobs() {
  ImageGeometry g;
  g.size = {80, 70, 60};
  g.spacing = Vector3d::Constant(0.5);
  g.origin = Vector3d(-20, 30, 10);
  VolumeF v(g, 1);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0, 1);
  struct Blob {
    Vector3d c;
    double sigma, amplitude;
  };
  std::vector<Blob> b;
  for (int n = 0; n < 40; ++n)
    b.push_back({g.index_to_world(Vector3d(u(rng) * 79, u(rng) * 69, u(rng) * 59)),
                 1.5 + 2.5 * u(rng), (u(rng) - 0.5) * 160});
  for (int k = 0; k < 60; ++k)
    for (int j = 0; j < 70; ++j)
      for (int i = 0; i < 80; ++i) {
        const Vector3d p = g.index_to_world(Vector3d(i, j, k));
        double x = 120;
        for (const Blob& q : b)
          x += q.amplitude * std::exp(-(p - q.c).squaredNorm() / (2 * q.sigma * q.sigma));
        v.at(i, j, k) = float(std::clamp(x, 0.0, 255.0));
      }
  return v;
}

TEST(VolumeReconstruction, ASweepCutFromASmoothVolumeReconstructsIt) {
  // Pixels of 0.3 mm, frames 0.8 mm apart (gaps of a voxel and more to fill; frames 17 and 18
  // invalid leave 2.4 mm), stored UF.
  check_round_trip(blobs(), 0.3, 0.8, 26, "UF");
}

TEST(VolumeReconstruction, ASweepCutFromARealBModeVolumeReconstructsIt) {
  const fs::path file = fs::path(tests::shared_data_dir) / "resect" / "Case1.nii.gz";
  if (!fs::exists(file)) GTEST_SKIP() << "shared data absent: " << file;
  const VolumeF truth = read_volume(file);
  // Real speckle at the volume's own 0.5 mm: pixels of 0.25 mm, frames 0.6 mm apart.
  const double c = check_round_trip(truth, 0.25, 0.6, 60, "MF");
  RecordProperty("correlation", std::to_string(c));
}

TEST(PlusSequence, OrientationStatusAndBadFiles) {
  const tests::TempFolder dir;
  const Sweep s = cut_sweep(blobs(), 1.0, 2.0, 4, {2});
  write_plus_sequence(dir / "mf.seq.mha", s, "MF");
  write_plus_sequence(dir / "un.seq.mha", s, "UN");
  const PlusSequence mf = read_plus_sequence(dir / "mf.seq.mha");
  const PlusSequence un = read_plus_sequence(dir / "un.seq.mha");
  ASSERT_EQ(mf.frames.size(), 4u);
  EXPECT_EQ(un.orientation_in_file, "UN");
  EXPECT_TRUE(mf.pixels == un.pixels) << "both turned to MF on reading";
  EXPECT_TRUE(mf.frames[2].transforms.empty());
  ASSERT_EQ(mf.frames[2].invalid.size(), 1u);
  EXPECT_EQ(mf.frames[2].invalid[0], "ProbeToTracker");
  EXPECT_NEAR(mf.frames[3].timestamp, 0.15, 1e-12);
  EXPECT_TRUE(mf.frames[0].transforms.at("ProbeToTracker").isApprox(s.probe_to_tracker[0], 1e-12));
  // Without a calibration there is no Image-to-world transform in this file: said, with names.
  tests::expect_error([&] { (void)image_to_world(mf, "mf.seq.mha", std::nullopt); },
                      {"mf.seq.mha", "ProbeToTrackerTransform", "--calibration"});

  // The same sweep as PLUS's NRRD sequence (gzip, stored UN) and as a compressed MetaImage
  // sequence (CompressedData = True: zlib) reads the same.
  tests::write_plus_sequence_nrrd(dir / "un.seq.nrrd", s, "UN");
  const PlusSequence nrrd = read_plus_sequence(dir / "un.seq.nrrd");
  EXPECT_TRUE(nrrd.pixels == mf.pixels);
  ASSERT_EQ(nrrd.frames.size(), 4u);
  EXPECT_TRUE(nrrd.frames[2].transforms.empty());
  EXPECT_TRUE(
      nrrd.frames[1].transforms.at("ProbeToTracker").isApprox(s.probe_to_tracker[1], 1e-12));
  {
    std::ifstream raw_in(dir / "mf.seq.mha", std::ios::binary);
    std::string all_mha((std::istreambuf_iterator<char>(raw_in)), std::istreambuf_iterator<char>());
    const auto at_data = all_mha.find("ElementDataFile = LOCAL\n") + 24;
    std::string header = all_mha.substr(0, at_data);
    header.replace(header.find("CompressedData = False"), 22, "CompressedData = True");
    std::ofstream(dir / "z.seq.mha", std::ios::binary)
        << header << tests::deflate_bytes(all_mha.substr(at_data), false);
    EXPECT_TRUE(read_plus_sequence(dir / "z.seq.mha").pixels == mf.pixels);
    // A header claiming far more pixels than the file can hold: refused before allocating.
    std::string huge = header;
    const auto dim_at = huge.find("DimSize = ");
    huge.replace(dim_at, huge.find('\n', dim_at) - dim_at, "DimSize = 90000 90000 4");
    std::ofstream(dir / "huge.seq.mha", std::ios::binary)
        << huge << tests::deflate_bytes(all_mha.substr(at_data), false);
    tests::expect_error([&] { read_plus_sequence(dir / "huge.seq.mha"); },
                        {"huge.seq.mha", "deflate"});
  }

  // The calibration recorded in every frame (ImageToProbeTransform) places the frames too.
  write_plus_sequence(dir / "cal.seq.mha", s, "MF", false, /*calibration_in_frames=*/true);
  const auto placed = image_to_world(read_plus_sequence(dir / "cal.seq.mha"), "cal", std::nullopt);
  ASSERT_EQ(placed.size(), 4u);
  EXPECT_FALSE(placed[2].has_value()) << "its ProbeToTracker is INVALID";
  ASSERT_TRUE(placed[1].has_value());
  EXPECT_TRUE(placed[1]->isApprox(s.probe_to_tracker[1] * s.calibration, 1e-12));

  // Bad files: one line naming the file.
  const auto text = [&](const std::string& name, const std::string& content) {
    std::ofstream(dir / name, std::ios::binary) << content;
    return dir / name;
  };
  tests::expect_error([&] { read_plus_sequence(text("a.seq.mha", "hello\n")); },
                      {"a.seq.mha", "MetaImage"});
  std::ifstream in(dir / "mf.seq.mha", std::ios::binary);
  std::string all((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  tests::expect_error(
      [&] { read_plus_sequence(text("cut.seq.mha", all.substr(0, all.size() - 10))); },
      {"cut.seq.mha", "truncated"});
  std::string bad = all;
  bad.replace(bad.find("UltrasoundImageOrientation = MF"), 31, "UltrasoundImageOrientation = XY");
  tests::expect_error([&] { read_plus_sequence(text("o.seq.mha", bad)); },
                      {"o.seq.mha", "UltrasoundImageOrientation"});
  bad = all;
  const auto at = bad.find("Seq_Frame0001_ProbeToTrackerTransform = ") + 40;
  bad.replace(at, 3, "abc");
  tests::expect_error([&] { read_plus_sequence(text("m.seq.mha", bad)); },
                      {"m.seq.mha", "Seq_Frame0001_ProbeToTrackerTransform", "not a number"});
  tests::expect_error([&] { read_matrix_file(text("c.txt", "1 0 0 0 0 1 0 0 0 0 1 0")); },
                      {"c.txt", "16"});
}

}  // namespace
}  // namespace brainshift::imaging
