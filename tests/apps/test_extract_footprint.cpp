// `brainshift extract footprint` through the real executable: outputs, report keys, the given
// direction, warnings, and the bad-input contract (one-line error naming the file, nothing
// half-written).
#include "cli_helpers.hpp"

#include "imaging/footprint/footprint_io.hpp"
#include "imaging/footprint/synthetic_fan.hpp"
#include "imaging/io/image_io.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <fstream>
#include <sstream>

namespace brainshift {
namespace {

nlohmann::json read_json(const std::filesystem::path& p) {
  return nlohmann::json::parse(read_all(p));
}

std::string vector_arg(const Vector3d& v) {
  std::ostringstream s;
  s.precision(17);
  s << v.x() << ',' << v.y() << ',' << v.z();
  return s.str();
}

TEST(ExtractFootprint, WritesPointsNormalsAndTheReport) {
  const tests::TempFolder dir;
  const tests::Scene s = tests::render(tests::Fan{}, 21u);
  const auto bmode = dir.path() / "bmode.nii.gz";
  imaging::write_volume(bmode, s.image);
  const auto vtp = dir.path() / "footprint.vtp";
  const auto report = dir.path() / "report.json";
  const CliRun r = run_brainshift(
      dir, "extract footprint --bmode " + q(bmode) + " --out " + q(vtp) + " --report " + q(report));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("footprint of"), std::string::npos) << r.out;
  const imaging::FootprintPoints f = imaging::read_footprint_vtp(vtp);
  ASSERT_GE(f.points.rows(), 6);  // a 25 × 30 mm face on a 10 mm lattice
  const Vector3d beam = s.frame.col(2);
  for (Eigen::Index p = 0; p < f.points.rows(); ++p) {
    EXPECT_NEAR(f.normals.row(p).norm(), 1.0, 1e-9);  // unit normals
    EXPECT_GT(f.normals.row(p).dot(beam.transpose()),
              0.99);  // into the tissue: along the beam (< 8°)
  }
  const nlohmann::json j = read_json(report);
  for (const char* key : {"points", "probe_direction", "direction_source", "contrast", "width_mm",
                          "seconds", "warnings", "file"})
    EXPECT_TRUE(j.contains(key)) << key;
  EXPECT_EQ(j["points"].get<int>(), f.points.rows());
  EXPECT_EQ(j["direction_source"], "estimated");
  const Vector3d d(j["probe_direction"][0].get<double>(), j["probe_direction"][1].get<double>(),
                   j["probe_direction"][2].get<double>());
  EXPECT_GT(d.dot(beam),
            std::cos(3.0 * tests::kFanPi / 180.0));  // within 3° (test_imaging_footprint)
  EXPECT_TRUE(j["warnings"].empty()) << j["warnings"].dump();
}

TEST(ExtractFootprint, TakesTheGivenProbeDirection) {
  const tests::TempFolder dir;
  const tests::Scene s = tests::render(tests::Fan{}, 23u);
  const auto bmode = dir.path() / "bmode.nii.gz";
  imaging::write_volume(bmode, s.image);
  const auto report = dir.path() / "report.json";
  const CliRun r =
      run_brainshift(dir, "extract footprint --bmode " + q(bmode) + " --probe-direction " +
                              vector_arg(2.0 * Vector3d(s.frame.col(2))) + " --out " +
                              q(dir.path() / "f.vtp") + " --report " + q(report));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json j = read_json(report);
  EXPECT_EQ(j["direction_source"], "given");
  const Vector3d d(j["probe_direction"][0].get<double>(), j["probe_direction"][1].get<double>(),
                   j["probe_direction"][2].get<double>());
  EXPECT_NEAR((d - s.frame.col(2)).norm(), 0.0, 1e-9);  // normalised, otherwise as given
}

TEST(ExtractFootprint, ASmallFootprintIsAWarningOnStderrAndInTheReport) {
  const tests::TempFolder dir;
  tests::Fan fan;
  fan.near_width = 6.0;
  fan.elevation = 6.0;
  fan.half_angle_deg = 35.0;
  fan.tilt_deg = 20.0;
  const tests::Scene s = tests::render(fan, 17u);
  const auto bmode = dir.path() / "bmode.nii.gz";
  imaging::write_volume(bmode, s.image);
  const auto report = dir.path() / "report.json";
  const CliRun r = run_brainshift(dir, "extract footprint --bmode " + q(bmode) + " --out " +
                                           q(dir.path() / "f.vtp") + " --report " + q(report));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("[warning] footprint: small footprint"), std::string::npos) << r.err;
  const nlohmann::json j = read_json(report);
  ASSERT_FALSE(j["warnings"].empty());
  EXPECT_NE(j["warnings"][0].get<std::string>().find("small footprint"), std::string::npos);
}

TEST(ExtractFootprint, BadInputsAreOneLineErrorsAndWriteNothing) {
  const tests::TempFolder dir;
  const auto vtp = dir.path() / "f.vtp";
  const auto report = dir.path() / "r.json";
  const std::string outputs = " --out " + q(vtp) + " --report " + q(report);

  // No contact band: the near field as dark as the tissue.
  tests::Fan dark;
  dark.band_echo = 1.0;
  const auto no_band = dir.path() / "no_band.nii.gz";
  imaging::write_volume(no_band, tests::render(dark, 25u).image);
  CliRun r = run_brainshift(dir, "extract footprint --bmode " + q(no_band) + outputs);
  expect_one_line_error(r, "no_band.nii.gz: no contact band found");

  // Nothing swept: every voxel 0.
  imaging::VolumeF zero = tests::render(tests::Fan{}, 27u).image;
  std::fill(zero.data.begin(), zero.data.end(), 0.0F);
  const auto empty = dir.path() / "zero.nii.gz";
  imaging::write_volume(empty, zero);
  r = run_brainshift(dir, "extract footprint --bmode " + q(empty) + outputs);
  expect_one_line_error(r, "zero.nii.gz: no swept region");

  // A missing file, a malformed and a zero direction.
  r = run_brainshift(dir, "extract footprint --bmode " + q(dir.path() / "absent.nii.gz") + outputs);
  expect_one_line_error(r, "absent.nii.gz");
  r = run_brainshift(
      dir, "extract footprint --bmode " + q(no_band) + " --probe-direction 1,2" + outputs);
  expect_one_line_error(r, "--probe-direction");
  r = run_brainshift(
      dir, "extract footprint --bmode " + q(no_band) + " --probe-direction 0,0,0" + outputs);
  expect_one_line_error(r, "zero length");
  // An output folder that does not exist: refused before the work.
  r = run_brainshift(dir, "extract footprint --bmode " + q(no_band) + " --out " +
                              q(dir.path() / "nope" / "f.vtp"));
  expect_one_line_error(r, "nope");

  EXPECT_FALSE(std::filesystem::exists(vtp));
  EXPECT_FALSE(std::filesystem::exists(report));
  for (const auto& entry : std::filesystem::directory_iterator(dir.path()))
    EXPECT_EQ(entry.path().extension(), ".gz") << "left behind: " << entry.path();
}

}  // namespace
}  // namespace brainshift
