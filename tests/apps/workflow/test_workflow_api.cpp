// The workflow library called directly (no executable): prepare_model() and register_and_write()
// on the phantom 'standard', checked against the command line on the same inputs — the model the
// CLI prepares is the same size, and the CLI's registration of the library's model gives the same
// TRE (brainshift evaluate on both result folders). One test: the phantom takes ≈ 10 s.

#include "file_bytes.hpp"

#include "apps/cli_helpers.hpp"
#include "apps/workflow/prepare.hpp"
#include "apps/workflow/progress.hpp"
#include "apps/workflow/register.hpp"
#include "apps/workflow/result_report.hpp"
#include "apps/workflow/session.hpp"
#include "data_synth/cases/phantom_case.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>
#include <zlib.h>

namespace brainshift {
namespace {

nlohmann::json read_json(const std::filesystem::path& p) {
  return nlohmann::json::parse(read_all(p));
}

/// The phantom `standard` (seed 1) written to DIR/phantom, and the options that prepare its model
/// (labels and MRA) into DIR/MODEL.
workflow::PrepareOptions standard_phantom(const std::filesystem::path& dir,
                                          const std::string& model) {
  data_synth::CaseOptions co;
  co.out = dir / "phantom";
  (void)data_synth::generate_case("standard", 1, co);
  workflow::PrepareOptions po;
  po.labels = co.out / "preop/labels.nii.gz";
  po.mra = co.out / "preop/mra.nii.gz";
  po.out = dir / model;
  return po;
}

TEST(WorkflowApi, PrepareAndRegisterMatchTheCommandLine) {
  const tests::TempFolder dir;
  const auto ph = dir / "phantom";
  // prepare: library and command line on the same inputs.
  const workflow::PrepareOptions po = standard_phantom(dir.path(), "model_api");
  const workflow::PrepareResult prepared =
      workflow::prepare_model(po, workflow::Progress("prepare"));
  for (const char* f : {"scene.json", "model.json", "mesh.vtu", "surface.vtp", "fixed.csv"})
    EXPECT_TRUE(std::filesystem::exists(po.out / f)) << f;
  CliRun r = run_brainshift(dir, "prepare --labels " + q(po.labels) + " --mra " + q(po.mra) +
                                     " --out " + q(dir / "model_cli"));
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  const nlohmann::json manifest = read_json(dir / "model_cli/model.json");
  // Meshing and the vessel fit are deterministic: the same counts exactly.
  EXPECT_EQ(prepared.nodes, manifest["mesh"]["nodes"].get<index_t>());
  EXPECT_EQ(prepared.tets, manifest["mesh"]["tets"].get<index_t>());
  EXPECT_EQ(prepared.fixed_nodes, manifest["fixed"]["nodes"].get<std::size_t>());
  EXPECT_EQ(prepared.vessel_points_snapped, manifest["vessels"]["snapped"].get<index_t>());
  EXPECT_EQ(prepared.vessel_points_dropped, manifest["vessels"]["dropped"].get<index_t>());

  // register: library and command line on the library's model.
  workflow::RegisterOptions ro;
  ro.model = po.out;
  ro.doppler = ph / "intraop/doppler.nii.gz";
  ro.out = dir / "res_api";
  const workflow::RegisterOutcome outcome =
      workflow::register_and_write(ro, workflow::Progress("register"));
  EXPECT_TRUE(outcome.result.positions.allFinite());
  r = run_brainshift(dir, "register --model " + q(ro.model) + " --doppler " + q(ro.doppler) +
                              " --out " + q(dir / "res_cli"));
  // 0 = converged, 2 = stopped without meeting the convergence test; both write the result.
  ASSERT_TRUE(r.exit_code == 0 || r.exit_code == 2) << r.out << r.err;
  EXPECT_EQ(r.exit_code == 0, outcome.result.converged);
  const nlohmann::json report_api = read_json(ro.out / "report.json");
  const nlohmann::json report_cli = read_json(dir / "res_cli/report.json");
  EXPECT_EQ(report_api["iterations"], report_cli["iterations"]);
  // Same code on the same inputs; 1e-6 mm allows for summation order in threaded kernels.
  EXPECT_NEAR(report_api["max_displacement_mm"].get<double>(), outcome.max_displacement_mm, 1e-12)
      << "the outcome is what was written";
  EXPECT_NEAR(report_api["max_displacement_mm"].get<double>(),
              report_cli["max_displacement_mm"].get<double>(), 1e-6);

  double tre[2] = {0.0, 0.0};
  int k = 0;
  for (const auto& res : {ro.out, dir / "res_cli"}) {
    r = run_brainshift(dir, "evaluate --result " + q(res) + " --landmarks-pre " +
                                q(ph / "truth/landmarks_preop.csv") + " --landmarks-intra " +
                                q(ph / "truth/landmarks_intraop.csv"));
    ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
    tre[k++] = read_json(res / "evaluation.json")["tre_after_mm"]["mean"].get<double>();
  }
  // Same answer, so the same TRE (1e-6 mm as above), and a finite, registered one.
  EXPECT_NEAR(tre[0], tre[1], 1e-6);
  EXPECT_TRUE(std::isfinite(tre[0]));
}

/// A file's bytes; a .gz file's decompressed bytes (the compressed stream may differ).
using tests::content;

/// report.json without what depends on the clock: `timing` and every key naming seconds.
nlohmann::json without_times(nlohmann::json j) {
  if (j.is_object()) {
    nlohmann::json out = nlohmann::json::object();
    for (auto it = j.begin(); it != j.end(); ++it)
      if (it.key() != "timing" && it.key().find("seconds") == std::string::npos)
        out[it.key()] = without_times(it.value());
    return out;
  }
  if (j.is_array())
    for (auto& v : j) v = without_times(v);
  return j;
}

TEST(WorkflowApi, OutputsWrittenOnTwoThreadsEqualTheSerialOnes) {
  // write_result() computes the fields on two threads and writes each file as soon as its field
  // is there; with threads = 1 everything is done in turn. Every file must be the same (a .gz by
  // its decompressed bytes), report.json apart from its times, with and without an MRI.
  const tests::TempFolder dir;
  const auto ph = dir / "phantom";
  const workflow::PrepareOptions po = standard_phantom(dir.path(), "model");
  (void)workflow::prepare_model(po, workflow::Progress("prepare"));
  const workflow::Session s = workflow::open_session(po.out);
  const workflow::IntraopInputs in =
      workflow::read_intraop(s, ph / "intraop/doppler.nii.gz", std::nullopt);
  const imaging::VolumeF mri = workflow::read_preop_mri(s, ph / "preop/mri.nii.gz");
  const constraints::RegistrationResult r =
      constraints::register_model(*s.model, in.data, s.loaded.scene.options);
  for (const bool with_mri : {true, false}) {
    SCOPED_TRACE(with_mri ? "with the MRI" : "without an MRI");
    const imaging::VolumeF* m = with_mri ? &mri : nullptr;
    workflow::write_result(dir / "serial", s, r, in, m, {}, /*with_uncertainty=*/true,
                           /*threads=*/1);
    workflow::write_result(dir / "parallel", s, r, in, m, {}, /*with_uncertainty=*/true,
                           /*threads=*/2);
    std::vector<std::string> names;
    for (const auto& e : std::filesystem::directory_iterator(dir / "serial"))
      names.push_back(e.path().filename().string());
    // report, mesh, 4 volumes, overlay; with the MRI also the warped MRI and a second overlay
    EXPECT_EQ(names.size(), with_mri ? 9U : 7U);
    for (const std::string& name : names) {
      SCOPED_TRACE(name);
      ASSERT_TRUE(std::filesystem::exists(dir / "parallel" / name));
      if (name == "report.json") {
        EXPECT_EQ(without_times(read_json(dir / "serial" / name)),
                  without_times(read_json(dir / "parallel" / name)));
        continue;
      }
      const std::vector<char> a = content(dir / "serial" / name);
      EXPECT_FALSE(a.empty());
      EXPECT_TRUE(a == content(dir / "parallel" / name)) << "contents differ";
    }
  }
}

}  // namespace
}  // namespace brainshift
