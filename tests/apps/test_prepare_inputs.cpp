// `brainshift prepare` on label volumes that cannot make a model: one line on stderr naming the
// file and the problem, nothing written.

#include <gtest/gtest.h>

#include <functional>
#include <string>

#include "cli_helpers.hpp"
#include "imaging/io/image_io.hpp"

namespace brainshift {
namespace {

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
    return run_brainshift(dir, "prepare --labels " + q(labels) + " --mra " + q(mra) + " --out " + q(out));
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

}  // namespace
}  // namespace brainshift
