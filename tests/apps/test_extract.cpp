// `brainshift extract vessels`: the skeleton, the report and the PNG from an angiogram; one-line
// errors naming the file for no vessels, a missing image or folder; a warning for a weak input.

#include "../imaging/vessels/angiogram_standins.hpp"
#include "cli_helpers.hpp"

#include "imaging/io/image_io.hpp"
#include "imaging/io/skeleton_io.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <string>

namespace brainshift {
namespace {

TEST(ExtractVessels, WritesTheSkeletonReportAndProjection) {
  const tests::TempFolder dir;
  // The background-suppressed TOF stand-in, its float sform orthonormal only to 1.3e-6.
  imaging::write_volume(dir / "tof.nii.gz", tests::suppressed_tof().image);
  const CliRun r = run_brainshift(dir, "extract vessels --image " + q(dir / "tof.nii.gz") +
                                           " --out " + q(dir / "skeleton.vtp") + " --report " +
                                           q(dir / "report.json") + " --png " + q(dir / "mip.png"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("extracted"), std::string::npos) << r.out;
  const nlohmann::json report = nlohmann::json::parse(read_all(dir / "report.json"));
  for (const char* key : {"branches", "length_mm", "points", "threshold", "seconds"})
    EXPECT_TRUE(report.contains(key)) << key;
  const imaging::VesselGraph g = imaging::read_skeleton_vtp(dir / "skeleton.vtp");
  EXPECT_EQ(report["branches"].get<std::size_t>(), g.branches.size());
  // The file holds the graph as written: same length to float precision (0.01 mm).
  EXPECT_NEAR(report["length_mm"].get<double>(), g.total_length(), 1e-2);
  EXPECT_GT(report["length_mm"].get<double>(),
            200.0);  // the ≈ 277 mm circle of Willis, mostly found
  EXPECT_LT(report["threshold"].get<double>(), 254.0);
  ASSERT_EQ(report["header_notes"].size(), 1U);
  EXPECT_NE(report["header_notes"][0].get<std::string>().find("re-orthonormalised"),
            std::string::npos);
  const std::string png = read_all(dir / "mip.png");
  ASSERT_GT(png.size(), 8U);
  EXPECT_EQ(png.substr(1, 3), "PNG");
}

TEST(ExtractVessels, AnImageWithoutVesselsIsAOneLineErrorNamingIt) {
  const tests::TempFolder dir;
  imaging::ImageGeometry g;
  g.size = {40, 40, 30};
  imaging::VolumeF flat = tests::correlated_noise(g, 20.0, 1.0, 5);
  for (float& v : flat.data) v += 300.0F;
  imaging::write_volume(dir / "flat.nii.gz", flat);
  const CliRun r =
      run_brainshift(dir, "extract vessels --image " + q(dir / "flat.nii.gz") + " --out " +
                              q(dir / "skeleton.vtp") + " --report " + q(dir / "report.json"));
  expect_one_line_error(r, "flat.nii.gz");
  EXPECT_NE(r.err.find("no vessels"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir / "skeleton.vtp"));
  EXPECT_FALSE(std::filesystem::exists(dir / "report.json"));
}

TEST(ExtractVessels, MissingImageOrOutputFolderIsAOneLineError) {
  const tests::TempFolder dir;
  CliRun r = run_brainshift(
      dir, "extract vessels --image " + q(dir / "absent.nii.gz") + " --out " + q(dir / "s.vtp"));
  expect_one_line_error(r, "absent.nii.gz");
  imaging::ImageGeometry g;
  g.size = {8, 8, 8};
  imaging::write_volume(dir / "small.nii.gz", imaging::VolumeF(g, 1, 1.0F));
  r = run_brainshift(dir, "extract vessels --image " + q(dir / "small.nii.gz") + " --out " +
                              q(dir / "no_such_folder" / "s.vtp"));
  expect_one_line_error(r, "no_such_folder");
  r = run_brainshift(dir, "extract");
  EXPECT_NE(r.exit_code, 0);  // a subcommand is required
}

TEST(ExtractVessels, AWeakInputWarnsInTheReportAndOnStderr) {
  const tests::TempFolder dir;
  // One short vessel (20 mm): usable, but few vessels for a registration.
  imaging::ImageGeometry g;
  g.size = {48, 32, 32};
  g.spacing = {0.8, 0.8, 0.8};
  imaging::write_volume(dir / "short.nii.gz",
                        tests::draw_tubes(g, {{{8, 12, 12}, {28, 12, 12}}}, 1.6));
  const CliRun r =
      run_brainshift(dir, "extract vessels --image " + q(dir / "short.nii.gz") + " --out " +
                              q(dir / "s.vtp") + " --report " + q(dir / "report.json"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("brainshift: warning: "), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("few vessels"), std::string::npos) << r.err;
  const nlohmann::json report = nlohmann::json::parse(read_all(dir / "report.json"));
  ASSERT_GE(report["warnings"].size(), 1U);
  EXPECT_NE(report["warnings"][0].get<std::string>().find("few vessels"), std::string::npos);
}

}  // namespace
}  // namespace brainshift
