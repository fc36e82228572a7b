// `brainshift prepare` on inputs that cannot make a model: label volumes without a brain, an
// angiogram whose vessels all lie far from the brain. One line on stderr naming the file and the
// problem, nothing written.

#include "cli_helpers.hpp"

#include "imaging/io/image_io.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <string>

namespace brainshift {
namespace {

using Eigen::Vector2d;

imaging::ImageGeometry small_grid() {
  imaging::ImageGeometry g;
  g.size = Eigen::Vector3i::Constant(24);
  g.spacing = Vector3d::Constant(2.0);
  g.origin = Vector3d::Constant(-23.0);
  return g;
}

/// A label volume of small_grid() with `label` inside a 15 mm ball, 0 outside (written as a
/// float image: write_labels() refuses values other than 0–3, other programs do not).
void write_ball_labels(const std::filesystem::path& path, int label) {
  imaging::VolumeF v(small_grid());
  const auto& g = v.geometry;
  for (int k = 0; k < g.size[2]; ++k)
    for (int j = 0; j < g.size[1]; ++j)
      for (int i = 0; i < g.size[0]; ++i)
        v.at(i, j, k) = g.index_to_world(Vector3d(i, j, k)).norm() < 15.0 ? float(label) : 0.0F;
  imaging::write_volume(path, v);
}

TEST(PrepareInputs, LabelVolumesWithoutBrainAreOneLineErrorsNamingTheFile) {
  const tests::TempFolder dir;
  const auto mra = dir / "mra.nii.gz";
  imaging::write_volume(mra, imaging::VolumeF(small_grid(), 1, 60.0F));
  const auto out = dir / "model";
  const auto prepare = [&](const std::filesystem::path& labels) {
    return run_brainshift(
        dir, "prepare --labels " + q(labels) + " --mra " + q(mra) + " --out " + q(out));
  };
  struct Case {
    const char* file;
    int label;
    const char* problem;
  };
  for (const Case& c : {Case{"all_background.nii.gz", 0, "every voxel is background"},
                        Case{"only_ventricles.nii.gz", 3, "no voxel has label 1"},
                        Case{"only_tumour.nii.gz", 2, "no voxel has label 1"},
                        Case{"freesurfer_like.nii.gz", 17, "17"}}) {
    SCOPED_TRACE(c.file);
    write_ball_labels(dir / c.file, c.label);
    const CliRun r = prepare(dir / c.file);
    expect_one_line_error(r, c.file);
    expect_one_line_error(r, c.problem);
    EXPECT_FALSE(std::filesystem::exists(out));
  }
  // One voxel of brain (8 mm³) is no brain either (CGAL would mesh it: 38 nodes).
  imaging::LabelVolume speck(small_grid());
  speck.at(12, 12, 12) = 1;
  imaging::write_labels(dir / "speck.nii.gz", speck);
  const CliRun r = prepare(dir / "speck.nii.gz");
  expect_one_line_error(r, "speck.nii.gz");
  expect_one_line_error(r, "only 0.008 mL");
  EXPECT_FALSE(std::filesystem::exists(out));
}

TEST(PrepareInputs, AnAngiogramWhoseVesselsAllLieFarOutsideTheBrainIsAnErrorNamingIt) {
  // A 40 mm brain ball (268 mL) and an MRA whose only vessel, a straight tube of radius 2 mm,
  // runs 15 mm above it: every skeleton point is beyond the 5 mm snap distance.
  imaging::ImageGeometry g;
  g.size = Eigen::Vector3i::Constant(64);
  g.spacing = Vector3d::Constant(2.0);
  g.origin = Vector3d::Constant(-63.0);
  imaging::LabelVolume labels(g);
  imaging::VolumeF mra(g);
  for (int k = 0; k < g.size[2]; ++k)
    for (int j = 0; j < g.size[1]; ++j)
      for (int i = 0; i < g.size[0]; ++i) {
        const Vector3d p = g.index_to_world(Vector3d(i, j, k));
        labels.at(i, j, k) = p.norm() < 40.0 ? 1 : 0;
        const double d = Vector2d(p.y(), p.z() - 55.0).norm();  // tube along x at z = 55 mm
        mra.at(i, j, k) = float(60.0 + 240.0 * std::clamp(2.0 + 1.0 - d, 0.0, 1.0) +
                                8.0 * std::sin(7.1 * i + 3.3 * j + 1.7 * k));
      }
  const tests::TempFolder dir;
  imaging::write_labels(dir / "ball.nii.gz", labels);
  imaging::write_volume(dir / "far_vessels.nii.gz", mra);
  const auto out = dir / "model";
  const CliRun r = run_brainshift(dir, "prepare --labels " + q(dir / "ball.nii.gz") + " --mra " +
                                           q(dir / "far_vessels.nii.gz") + " --out " + q(out));
  expect_one_line_error(r, "far_vessels.nii.gz");
  expect_one_line_error(r, "within 5 mm");
  EXPECT_FALSE(std::filesystem::exists(out));
}

}  // namespace
}  // namespace brainshift
