// `brainshift bench --quick` end to end (the CI smoke test of issue 8, < 2 min): every output
// file, the CSV/JSON contract, finite figures, and the bad-argument contract.

#include "cli_helpers.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <string>

namespace brainshift {
namespace {

nlohmann::json read_json(const std::filesystem::path& p) {
  std::ifstream in(p);
  return nlohmann::json::parse(in);
}

TEST(Bench, QuickWritesResultsTablePlotAndFiniteFigures) {
  const tests::TempFolder dir;
  const auto out = dir / "bench";
  const CliRun r = run_brainshift(dir, "bench --quick --out " + q(out));
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  for (const char* f :
       {"results.csv", "results.json", "results.md", "pareto.png", "pareto.gp", "pareto.dat"})
    EXPECT_TRUE(std::filesystem::exists(out / f)) << f;
  EXPECT_FALSE(std::filesystem::exists(out / "work"))
      << "work files are removed without --keep-work";

  // CSV: the header names the columns scripts rely on; one line per run.
  std::ifstream csv(out / "results.csv");
  std::string header;
  std::getline(csv, header);
  for (const char* col :
       {"suite", "case", "sweep", "value", "method", "nodes", "rows", "iterations", "stop",
        "registration_s", "peak_rss_mib", "tre_mean_mm", "tre_p95_mm", "shift_corrected_pct"})
    EXPECT_NE(header.find(col), std::string::npos) << col;
  int lines = 0;
  for (std::string l; std::getline(csv, l);) ++lines;

  const auto j = read_json(out / "results.json");
  EXPECT_EQ(j["machine"]["build_type"], "Release")
      << "figures are recorded from Release builds only";
  ASSERT_EQ(static_cast<int>(j["runs"].size()), lines);
  std::set<std::string> methods, sweeps;
  for (const auto& run : j["runs"]) {
    SCOPED_TRACE(run.dump());
    EXPECT_TRUE(run["ok"].get<bool>());
    methods.insert(run["method"].get<std::string>());
    if (!run["sweep"].get<std::string>().empty()) sweeps.insert(run["sweep"].get<std::string>());
    // The phantom's shift is 7 mm mean: any finite registration lies within 0–50 mm.
    EXPECT_GE(run["tre_mean_mm"].get<double>(), 0.0);
    EXPECT_LT(run["tre_mean_mm"].get<double>(), 50.0);
    EXPECT_GT(run["tre_before_mean_mm"].get<double>(), 1.0);
    EXPECT_GT(run["peak_rss_mib"].get<double>(), 1.0);
    EXPECT_GT(run["nodes"].get<int>(), 500);
  }
  EXPECT_EQ(methods,
            (std::set<std::string>{"constraint_icp", "old_loop", "navigation_prior",
                                   "bulk_start_only", "rigid_only", "prescribed_displacement",
                                   "pre_dura", "pre_dura_z1", "pre_dura_z2", "pre_dura_start_only",
                                   "pre_dura_from_rest", "pre_dura_no_tail"}));
  // The pose from the pre-dura sweep keeps the unmoving brain where it is: over 500 points in
  // the whole brain the error is measured 2.9 mm against 9.0 mm with the pose searched after the
  // dura is opened (which absorbs the sag and moves the fixed base); asked: under half.
  double dense_icp = -1, dense_pre = -1;
  for (const auto& run : j["runs"])
    if (run["suite"] == "cases" && run["case"] == "standard" &&
        run["uncertainty_dense_actual_mean_mm"].is_number()) {
      if (run["method"] == "constraint_icp")
        dense_icp = run["uncertainty_dense_actual_mean_mm"].get<double>();
      if (run["method"] == "pre_dura")
        dense_pre = run["uncertainty_dense_actual_mean_mm"].get<double>();
    }
  ASSERT_GT(dense_icp, 0.0);
  ASSERT_GT(dense_pre, 0.0);
  EXPECT_LT(dense_pre, 0.5 * dense_icp);
  // The whole-brain error of every method (dense_error_mean_mm, mapped directly) agrees with the
  // predicted-error path's actual error where both exist (two code paths, one truth), and is
  // present for the baselines, which have no predicted error: rigid alone moves the whole brain
  // with the pose fitted to the sag (measured 9.4 mm, against 8.8 for ours and 4.1 with no
  // registration), so it is at least as far off as ours here.
  std::map<std::string, double> dense;
  for (const auto& run : j["runs"])
    if (run["suite"] == "cases" && run["case"] == "standard") {
      SCOPED_TRACE(run.dump());
      ASSERT_TRUE(run["dense_error_mean_mm"].is_number());
      dense[run["method"].get<std::string>()] = run["dense_error_mean_mm"].get<double>();
    }
  EXPECT_NEAR(dense["constraint_icp"], dense_icp, 1e-9);
  EXPECT_NEAR(dense["pre_dura"], dense_pre, 1e-9);
  EXPECT_GE(dense["rigid_only"], dense["constraint_icp"]);
  EXPECT_GT(dense["prescribed_displacement"], 0.0);
  // With RESECT's navigation prior the model's bulk response, not the pose, carries the sag and
  // the fixed base stays: measured 4.1 mm over the whole brain against the default's 9.4 (the
  // 4 mm prior of the literature: 2.1); asked: under 0.6 × the default. No registration (the
  // same points' pre-operative positions against their truth) is 4.1 mm.
  EXPECT_LT(dense["navigation_prior"], 0.6 * dense["constraint_icp"]);
  for (const auto& run : j["runs"])
    if (run["suite"] == "cases" && run["case"] == "standard") {
      ASSERT_TRUE(run["dense_before_mean_mm"].is_number()) << run.dump();
      // The phantom's sag is 7 mm at the landmarks near the craniotomy, less towards the fixed
      // base: over the whole brain between 1 and 7 mm (measured 4.1).
      EXPECT_GT(run["dense_before_mean_mm"].get<double>(), 1.0);
      EXPECT_LT(run["dense_before_mean_mm"].get<double>(), 7.0);
      // The deep points (more than 60 mm from every vessel point the sweep saw): the phantom's
      // sag fades towards the fixed base, so they moved less than the brain on average (measured
      // 2.9 against 4.1 mm), and they are a real share of the 500 (measured 228).
      ASSERT_TRUE(run["dense_deep_before_mean_mm"].is_number()) << run.dump();
      EXPECT_LT(run["dense_deep_before_mean_mm"].get<double>(),
                run["dense_before_mean_mm"].get<double>());
      EXPECT_GT(run["dense_deep_points"].get<int>(), 50);
      EXPECT_LT(run["dense_deep_points"].get<int>(), 500);
      // Their error is the same points' error, so it is a mean over a subset of the whole brain's
      // points: at most the whole-brain mean × 500 / the subset's size.
      ASSERT_TRUE(run["dense_deep_error_mean_mm"].is_number()) << run.dump();
      EXPECT_LE(
          run["dense_deep_error_mean_mm"].get<double>() * run["dense_deep_points"].get<double>(),
          run["dense_error_mean_mm"].get<double>() * 500.0 + 1e-9);
    }
  EXPECT_EQ(sweeps, (std::set<std::string>{"mesh_size", "start", "vessel_sampling", "compliance",
                                           "pgs_tolerance", "constraint_sets"}));
  // Two mesh sizes give a growth exponent for the registration time.
  EXPECT_TRUE(j["fits"].contains("registration_s_vs_nodes")) << j["fits"].dump();
  // On `standard` our method must correct most of the shift (measured 75 %; asked ≥ 60 %, the
  // regression suite holds the tighter recorded figures), and the rigid-only baseline is a real
  // registration too (measured 80 % there: the phantom's shift is nearly a translation).
  double icp = -1, rigid = -1;
  for (const auto& run : j["runs"])
    if (run["suite"] == "cases" && run["case"] == "standard") {
      if (run["method"] == "constraint_icp") icp = run["shift_corrected_pct"].get<double>();
      if (run["method"] == "rigid_only") rigid = run["shift_corrected_pct"].get<double>();
    }
  EXPECT_GE(icp, 60.0);
  EXPECT_GE(rigid, 0.0);
  const std::string md = read_all(out / "results.md");
  EXPECT_NE(md.find("| cases | standard | constraint_icp |"), std::string::npos) << md;
}

// The predicted error's calibration on one phantom case against its independent (TLED) truth
// (issue 16): the bench's uncertainty columns for our default loop.
TEST(Bench, ElastixPeerRunsOnTheSameImagesAndIsScored) {
  // The image-registration peer (issue 32 item 5): Debian's elastix, a program we did not write,
  // on the phantom's MRA and Doppler. Its rigid stage must undo most of the shift: a wrong
  // RAS/LPS conversion of the points, or the transform applied in the wrong direction, would
  // leave errors at or beyond the shift itself (measured on standard seed 1: 7.23 → 2.12 mm
  // rigid, 3.09 mm with the B-spline stage, 23 s).
  if (std::system("command -v elastix > /dev/null 2>&1") != 0)
    GTEST_SKIP() << "elastix is not installed (scripts/install_deps.sh installs it)";
  const tests::TempFolder dir;
  const auto out = dir / "bench";
  const CliRun r =
      run_brainshift(dir, "bench --quick --suite cases --cases standard --elastix --out " + q(out));
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  const auto j = read_json(out / "results.json");
  std::map<std::string, nlohmann::json> by_method;
  for (const auto& run : j["runs"]) by_method[run["method"].get<std::string>()] = run;
  for (const char* m : {"elastix_rigid", "elastix"}) {
    ASSERT_TRUE(by_method.count(m)) << m;
    const auto& run = by_method[m];
    EXPECT_TRUE(run["ok"].get<bool>()) << run.dump();
    EXPECT_GT(run["registration_s"].get<double>(), 0.0);
    EXPECT_LT(run["tre_mean_mm"].get<double>(), run["tre_before_mean_mm"].get<double>())
        << run.dump();
    EXPECT_TRUE(run["dense_error_mean_mm"].is_number()) << run.dump();
  }
  EXPECT_GE(by_method["elastix_rigid"]["shift_corrected_pct"].get<double>(), 50.0)
      << by_method["elastix_rigid"].dump();
}

TEST(Bench, PredictedErrorIsCalibratedOnAPhantomCase) {
  const tests::TempFolder dir;
  const auto out = dir / "bench";
  const CliRun r =
      run_brainshift(dir, "bench --quick --suite cases --cases large_shift --out " + q(out));
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  const auto j = read_json(out / "results.json");
  const nlohmann::json* ours = nullptr;
  const nlohmann::json* pre_dura = nullptr;
  for (const auto& run : j["runs"]) {
    if (run["method"] == "constraint_icp") ours = &run;
    if (run["method"] == "pre_dura") pre_dura = &run;
  }
  ASSERT_NE(ours, nullptr) << j.dump();
  ASSERT_NE(pre_dura, nullptr) << j.dump();
  // The bars: RMS of actual / predicted within [0.5, 2] (1 = calibrated; a factor 2
  // either way is what the issue calls uncalibrated); Spearman ≥ 0.3 (clearly positive; one
  // landmark swapped moves it by ≈ 0.05 on 14 landmarks, its standard error on 500 dense points
  // is ≈ 0.04); within 2 sigma (the 3-D convention: a calibrated Gaussian gives 99.3 %) between
  // 70 and 100 %; larger far (> 10 mm) from the vessels than near (≤ 5 mm).
  {
    // The main path: the pose given by the pre-dura sweep, s² from the held-out vessel blocks
    // (UncertaintyOptions::ScaleEstimator::BY_POSE). Measured (seed 1, 2026-12-07): actual /
    // predicted RMS 0.94 at the 14 landmarks and 1.10 over the 500 dense points, 94 % of them
    // within 2 sigma. With maximum likelihood it was 0.18 and 0.21: the map 5 × too wide, ML
    // measuring the size of the sag rather than the fit's error.
    const auto& u = *pre_dura;
    SCOPED_TRACE(u.dump());
    EXPECT_EQ(u["uncertainty_s2_estimator"], "held_out_blocks");
    EXPECT_GT(u["uncertainty_rms_ratio"].get<double>(), 0.5);
    EXPECT_LT(u["uncertainty_rms_ratio"].get<double>(), 2.0);
    EXPECT_GE(u["uncertainty_within_2_sigma_pct"].get<double>(), 70.0);
    EXPECT_GT(u["uncertainty_dense_rms_ratio"].get<double>(), 0.5);
    EXPECT_LT(u["uncertainty_dense_rms_ratio"].get<double>(), 2.0);
    EXPECT_GE(u["uncertainty_dense_within_2_sigma_pct"].get<double>(), 70.0);
    EXPECT_GE(u["uncertainty_dense_spearman"].get<double>(), 0.3);
  }
  // One sweep, the pose searched on it: s² by maximum likelihood, conservative by design (the
  // pose may carry sag no held-out block can show). Measured (seed 1, 2026-12-07, the fixed
  // base at 30 %, s² at its 95 % upper bound, with the confounded-pose term): at the landmarks
  // Spearman 0.64, 100 % within 2 sigma, far 3.91 > near 1.67 mm, RMS ratio 0.46 (the map 2 ×
  // wide near the data; 0.27-1.45 over the 13 cases and seeds 1-3, docs/BENCHMARKS.md); over
  // the 500 dense points Spearman 0.81, 92 % within 2 sigma, RMS ratio 1.20, far 13.1 > near
  // 1.8 mm. Asked at the landmarks: never confidently wrong (RMS ratio < 2) and the ordering;
  // over the dense points, where 500 points measure the calibration, the two-sided bars.
  const auto& u = *ours;
  SCOPED_TRACE(u.dump());
  EXPECT_EQ(u["uncertainty_s2_estimator"], "maximum_likelihood");
  EXPECT_GE(u["uncertainty_spearman"].get<double>(), 0.3);
  EXPECT_GE(u["uncertainty_within_2_sigma_pct"].get<double>(), 70.0);
  EXPECT_GT(u["uncertainty_far_mean_mm"].get<double>(),
            u["uncertainty_near_mean_mm"].get<double>());
  EXPECT_LT(u["uncertainty_rms_ratio"].get<double>(), 2.0);
  // Dense calibration (500 points inside the brain against the phantom's truth field; without
  // the confounded-pose term it was 32 % within 2 sigma and an RMS ratio of 2.67, the map
  // under-predicting far from the data).
  ASSERT_TRUE(u["uncertainty_dense_points"].is_number()) << "no dense calibration";
  EXPECT_EQ(u["uncertainty_dense_points"].get<int>(), 500);
  EXPECT_GE(u["uncertainty_dense_spearman"].get<double>(), 0.3);
  EXPECT_GT(u["uncertainty_dense_far_mean_mm"].get<double>(),
            u["uncertainty_dense_near_mean_mm"].get<double>());
  EXPECT_GE(u["uncertainty_dense_within_2_sigma_pct"].get<double>(), 70.0);
  EXPECT_GT(u["uncertainty_dense_rms_ratio"].get<double>(), 0.5);
  EXPECT_LT(u["uncertainty_dense_rms_ratio"].get<double>(), 2.0);
  EXPECT_EQ(u["uncertainty_tracking_mm"].get<double>(), 0.0);  // large_shift declares none
  EXPECT_TRUE(std::filesystem::exists(out / "dense/large_shift.csv"));
}

TEST(Bench, BadArgumentsAreOneLineErrors) {
  const tests::TempFolder dir;
  expect_one_line_error(run_brainshift(dir, "bench --quick --cases nosuch --out " + q(dir / "b")),
                        "nosuch");
  expect_one_line_error(run_brainshift(dir, "bench --quick --out " + q(dir / "no/such/folder/b")),
                        "no/such/folder");
  EXPECT_FALSE(std::filesystem::exists(dir / "b"));
}

}  // namespace
}  // namespace brainshift
