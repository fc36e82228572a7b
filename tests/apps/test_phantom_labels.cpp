// `brainshift phantom --labels FILE` (issue 18) through the real executable: the bad-input
// contract (one line naming the value, nothing written), and on real anatomy (ICBM152, label
// `real`) the whole path: phantom → prepare → register → evaluate, converged and correcting the
// shift.

#include "cli_helpers.hpp"
#include "temp_folder.hpp"
#include "tests/config.hpp"

#include "data_synth/geometry/brain_phantom.hpp"
#include "imaging/io/image_io.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>

namespace brainshift {
namespace {

namespace fs = std::filesystem;

nlohmann::json read_json(const fs::path& p) {
  std::ifstream in(p);
  return nlohmann::json::parse(in);
}

/// The analytic phantom's labels at 3 mm (small and quick to read).
fs::path write_phantom_labels(const fs::path& dir) {
  data_synth::PhantomImageOptions io;
  io.spacing = 3.0;
  const fs::path f = dir / "labels.nii.gz";
  imaging::write_labels(f, data_synth::make_label_volume(data_synth::PhantomGeometry{}, io));
  return f;
}

TEST(PhantomLabels, BadInputsAreOneLineErrorsAndWriteNothing) {
  const tests::TempFolder dir;
  const fs::path labels = write_phantom_labels(dir.path());
  const fs::path out = dir.path() / "out";
  {
    imaging::LabelVolume empty = imaging::read_labels(labels);
    std::fill(empty.data.begin(), empty.data.end(), 0);
    imaging::write_labels(dir.path() / "empty.nii.gz", empty);
  }
  expect_one_line_error(run_brainshift(dir, "phantom --labels " + q(dir.path() / "empty.nii.gz") +
                                                " --out " + q(out)),
                        "has no brain");
  expect_one_line_error(
      run_brainshift(dir, "phantom --labels " + q(labels) + " --tumour 500,0,0,10 --out " + q(out)),
      "tumour centre (500, 0, 0) mm is outside the brain");
  expect_one_line_error(run_brainshift(dir, "phantom --labels " + q(labels) +
                                                " --tumour 1.5,-17,14.5,-2 --out " + q(out)),
                        "--tumour radius -2 mm must be positive");
  expect_one_line_error(run_brainshift(dir, "phantom --labels " + q(labels) +
                                                " --craniotomy 0,0,300 --out " + q(out)),
                        "craniotomy (0, 0, 300) mm is outside the brain");
  expect_one_line_error(
      run_brainshift(dir, "phantom --labels " + q(dir.path() / "none.nii.gz") + " --out " + q(out)),
      "none.nii.gz does not exist");
  expect_one_line_error(
      run_brainshift(dir, "phantom --case standard --tumour 0,0,0,5 --out " + q(out)),
      "--tumour and --craniotomy need --labels");
  expect_one_line_error(run_brainshift(dir, "phantom --out " + q(out)),
                        "--case NAME is required without --labels");
  // Nothing written: no output folder, no temporary sibling (only the inputs remain).
  EXPECT_FALSE(fs::exists(out));
  std::size_t entries = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir.path())) ++entries;
  EXPECT_EQ(entries, 2U);
}

TEST(PhantomLabels, Icbm152EndToEndConvergesAndCorrectsTheShift) {
  const fs::path labels = fs::path(tests::shared_data_dir) / "icbm152/labels.nii.gz";
  if (!fs::exists(labels))
    GTEST_SKIP() << "no real data: " << labels
                 << " is absent (this test needs ../shared/data/icbm152)";
  const tests::TempFolder dir;
  const fs::path ph = dir.path() / "phantom", model = dir.path() / "model",
                 res = dir.path() / "res";
  CliRun r = run_brainshift(dir, "phantom --labels " + q(labels) + " --seed 1 --out " + q(ph));
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  const auto c = read_json(ph / "case.json");
  EXPECT_EQ(c["truth_solver"]["status"], "converged");
  const auto& geo = c["parameters"]["geometry"];
  // Defaults: tumour 30 mm beneath the craniotomy (radius 10 mm), craniotomy on the upper
  // convexity: its outward normal within 45° of +S.
  EXPECT_NEAR(geo["tumour_depth_mm"].get<double>(), 30.0, 1e-6);
  EXPECT_EQ(geo["tumour_radius_mm"].get<double>(), 10.0);
  EXPECT_GT(geo["craniotomy_normal"][2].get<double>(), 0.7);
  // A shift of the size the issue describes for real anatomy (≈ 10 mm): at least 5 mm mean.
  EXPECT_GT(c["stats"]["mean_landmark_shift_mm"].get<double>(), 5.0);

  r = run_brainshift(dir, "prepare --labels " + q(ph / "preop/labels.nii.gz") + " --mra " +
                              q(ph / "preop/mra.nii.gz") + " --out " + q(model));
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  r = run_brainshift(dir, "register --model " + q(model) + " --doppler " +
                              q(ph / "intraop/doppler.nii.gz") + " --out " + q(res));
  // 0: converged (the "not settling" on real anatomy would be 2).
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_TRUE(read_json(res / "report.json")["converged"].get<bool>());
  r = run_brainshift(dir, "evaluate --result " + q(res) + " --landmarks-pre " +
                              q(ph / "truth/landmarks_preop.csv") + " --landmarks-intra " +
                              q(ph / "truth/landmarks_intraop.csv"));
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  const auto ev = read_json(res / "evaluation.json");
  // Measured 15.3 → 0.5 mm (97 % corrected, bench icbm_standard); require most of the shift
  // removed with a wide margin for the mesh's run-to-run variation: mean TRE below 2 mm and
  // 80 % corrected.
  EXPECT_LT(ev["tre_after_mm"]["mean"].get<double>(), 2.0) << ev.dump();
  EXPECT_GT(ev["shift_corrected_pct"].get<double>(), 80.0) << ev.dump();
}

}  // namespace
}  // namespace brainshift
