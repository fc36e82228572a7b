// The phantom regression suite (issue 8 item 3, CTest label `regression`): every named case, and
// the two cases on the real ICBM152 anatomy (issue 18; skipped when ../shared/data is absent),
// registered end to end by `brainshift bench --suite cases --cases NAME`, with thresholds on TRE
// and shift corrected taken from the recorded figures (tests/regression/thresholds.json) plus a
// stated margin; every run must give a finite answer with a stop reason, ours must converge, the
// "before" error must be the recorded one (the phantom did not change), and ours must not be
// behind the rigid-only baseline on the same data, at the landmarks and over the whole brain (the
// dense truth points), and the main path (the pose from the phantom's pre-dura sweep) must stay
// within its recorded landmark and whole-brain figures: issue 14 item 3, a gap of 0 plus a stated
// noise margin on every case, with no recorded shortfall (met since 2026-12-03: the start's bulk
// shift bounded to a sag and the noise model's paired test; docs/history/BENCHMARKS_NOTEBOOK.md,
// "Never worse than rigid, v7").

#include "tests/config.hpp"

#include "apps/cli_helpers.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <fstream>
#include <string>

namespace brainshift {
namespace {

nlohmann::json read_json(const std::filesystem::path& p) {
  std::ifstream in(p);
  return nlohmann::json::parse(in);
}

const nlohmann::json& thresholds() {
  static const nlohmann::json t =
      read_json(std::filesystem::path(tests::source_dir) / "tests/regression/thresholds.json");
  return t;
}

/// Ours against rigid alone: a gap of at most margin.rigid_gap_mm (record_thresholds.py says how
/// it was derived: the run-to-run noise of our figure, which the rigid baseline does not share).
double rigid_margin_mm() { return thresholds()["margin"]["rigid_gap_mm"].get<double>(); }

class PhantomCase : public ::testing::TestWithParam<std::string> {};

TEST_P(PhantomCase, RegistersWithinTheRecordedFiguresAndGapToRigid) {
  const std::string name = GetParam();
  // The cases on real anatomy (issue 18) read ../shared/data/icbm152: skipped when absent.
  const bool real = name.rfind("icbm_", 0) == 0;
  const std::filesystem::path real_data = tests::shared_data_dir;
  if (real && !std::filesystem::exists(real_data / "icbm152/labels.nii.gz"))
    GTEST_SKIP() << "no real data: " << (real_data / "icbm152").string() << " is absent (case "
                 << name << ")";
  const auto& t = thresholds();
  ASSERT_TRUE(t["cases"].contains(name)) << "no recorded figures for " << name;
  const auto& rec = t["cases"][name];
  const auto& margin = t["margin"];

  const tests::TempFolder dir;
  const CliRun r = run_brainshift(dir, "bench --suite cases --cases " + name + " --real-data " +
                                           q(real_data) + " --out " + q(dir / "b"));
  // 0: every run finite; 2 would mean a run failed or diverged.
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  const auto j = read_json(dir / "b" / "results.json");
  const nlohmann::json* icp = nullptr;
  const nlohmann::json* rigid = nullptr;
  const nlohmann::json* pre_dura = nullptr;
  for (const auto& run : j["runs"]) {
    SCOPED_TRACE(run.dump());
    EXPECT_TRUE(run["ok"].get<bool>());
    EXPECT_FALSE(run["stop"].get<std::string>().empty());
    // The phantom's own shift (before registration) does not depend on the method or the mesh:
    // the recorded figure to its 3 printed decimals.
    if (rec.contains("tre_before_mean_mm")) {
      EXPECT_NEAR(run["tre_before_mean_mm"].get<double>(), rec["tre_before_mean_mm"].get<double>(),
                  2e-3);
    }
    if (run["method"] == "constraint_icp") icp = &run;
    if (run["method"] == "rigid_only") rigid = &run;
    if (run["method"] == "pre_dura") pre_dura = &run;
  }
  ASSERT_TRUE(icp && rigid && pre_dura);
  EXPECT_EQ((*icp)["stop"].get<std::string>(), "converged") << name;
  // The pose from the phantom's pre-dura sweep (register --pre-dura) with the bulk shift carried
  // as the elastic rest: it settles on every case too (before the rest shape and DAMP,
  // large_shift and both ICBM152 cases hit the iteration cap; docs/history/BENCHMARKS_NOTEBOOK.md).
  EXPECT_EQ((*pre_dura)["stop"].get<std::string>(), "converged") << name << " (pre_dura)";
  // The main path's figures (issue 32: the pose from the pre-dura sweep), at the landmarks and
  // over the whole brain (the 500 dense truth points), within the same margins as ours below.
  // A recorded figure's allowance: recorded × tre_factor + the named additive margin (mm).
  auto allowed = [&](const char* recorded, const char* add) {
    return rec[recorded].get<double>() * margin["tre_factor"].get<double>() +
           margin[add].get<double>();
  };
  if (rec.contains("pre_dura_tre_mean_mm")) {
    const double pd = (*pre_dura)["tre_mean_mm"].get<double>();
    EXPECT_LE(pd, allowed("pre_dura_tre_mean_mm", "tre_add_mm"))
        << name << ": pre-dura mean TRE " << pd << " mm, recorded " << rec["pre_dura_tre_mean_mm"];
  }
  if (rec.contains("pre_dura_dense_error_mean_mm")) {
    ASSERT_TRUE((*pre_dura)["dense_error_mean_mm"].is_number()) << name << ": no dense truth";
    const double pd = (*pre_dura)["dense_error_mean_mm"].get<double>();
    EXPECT_LE(pd, allowed("pre_dura_dense_error_mean_mm", "dense_add_mm"))
        << name << ": pre-dura whole-brain mean error " << pd << " mm, recorded "
        << rec["pre_dura_dense_error_mean_mm"];
  }
  const double tre = (*icp)["tre_mean_mm"].get<double>();
  const double limit = allowed("tre_mean_mm", "tre_add_mm");
  EXPECT_LE(tre, limit) << name << ": mean TRE " << tre << " mm, recorded " << rec["tre_mean_mm"];
  const double pct =
      (*icp)["shift_corrected_pct"].is_null() ? 0.0 : (*icp)["shift_corrected_pct"].get<double>();
  EXPECT_GE(pct,
            rec["shift_corrected_pct"].get<double>() - margin["corrected_pct_drop"].get<double>())
      << name << ": recorded " << rec["shift_corrected_pct"];
  // Against rigid alone (the same global start's rigid pose, no deformation): a gap of 0, beyond
  // the stated noise margin (issue 14 item 3).
  const double rigid_tre = (*rigid)["tre_mean_mm"].get<double>();
  EXPECT_LE(tre - rigid_tre, rigid_margin_mm())
      << name << ": mean TRE " << tre << " mm, rigid only " << rigid_tre << " mm (gap to rigid "
      << tre - rigid_tre << " mm, margin " << rigid_margin_mm() << " mm)";
  // The same over the whole brain (the 500 dense truth points: bench_dense.hpp), where the 9–17
  // landmarks near the craniotomy cannot look and where the mechanics must carry the answer.
  const auto& dense_icp = (*icp)["dense_error_mean_mm"];
  const auto& dense_rigid = (*rigid)["dense_error_mean_mm"];
  ASSERT_TRUE(dense_icp.is_number() && dense_rigid.is_number()) << name << ": no dense truth";
  const double dense_gap = dense_icp.get<double>() - dense_rigid.get<double>();
  EXPECT_LE(dense_gap, margin["dense_rigid_gap_mm"].get<double>())
      << name << ": whole-brain mean error " << dense_icp << " mm, rigid only " << dense_rigid
      << " mm (margin " << margin["dense_rigid_gap_mm"] << " mm)";
}

// Few vessels in view through a large navigation offset (issue 32 item 4: one small cortical
// tree, sparse_vessels', seen through offset_12mm's 12 mm / 3° offset). Never confidently wrong:
// the default either gets it right (≤ 1.5 mm mean at the landmarks and converged), or says it
// cannot be trusted (exit 2: a stop other than converged, with its reason), or predicts an error
// at the landmarks of at least half the actual one. With the pre-dura sweep the offset is
// measured where there is no sag: converged, and as good as the recorded sparse_vessels bound.
TEST(SparseOffsetCase, IsNeverConfidentlyWrong) {
  const tests::TempFolder dir;
  const CliRun r =
      run_brainshift(dir, "bench --suite cases --cases sparse_offset_12mm --out " + q(dir / "b"));
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  const auto j = read_json(dir / "b" / "results.json");
  const nlohmann::json* icp = nullptr;
  const nlohmann::json* pre_dura = nullptr;
  for (const auto& run : j["runs"]) {
    if (run["method"] == "constraint_icp") icp = &run;
    if (run["method"] == "pre_dura") pre_dura = &run;
  }
  ASSERT_TRUE(icp && pre_dura) << j.dump();
  const double tre = (*icp)["tre_mean_mm"].get<double>();
  const std::string stop = (*icp)["stop"].get<std::string>();
  const double predicted = (*icp)["uncertainty_landmarks_mean_mm"].is_number()
                               ? (*icp)["uncertainty_landmarks_mean_mm"].get<double>()
                               : 0.0;
  const bool right = stop == "converged" && tre <= 1.5;
  const bool says_so = stop != "converged";
  const bool predicts_it = predicted >= 0.5 * tre;
  EXPECT_TRUE(right || says_so || predicts_it)
      << "mean TRE " << tre << " mm, stop " << stop << ", predicted " << predicted
      << " mm: " << (*icp)["stop_reason"];
  EXPECT_EQ((*pre_dura)["stop"].get<std::string>(), "converged") << (*pre_dura).dump();
}

INSTANTIATE_TEST_SUITE_P(Cases, PhantomCase,
                         ::testing::Values("standard", "large_shift",
                                           "deep_tumour_one_side_vessels", "noisy_doppler",
                                           "tracking_error", "sparse_vessels", "resection",
                                           "thin_structures", "offset_12mm", "offset_20mm",
                                           "icbm_standard", "icbm_offset_20mm"),
                         [](const ::testing::TestParamInfo<std::string>& p) { return p.param; });

}  // namespace
}  // namespace brainshift
