// The workflow library called directly (no executable): prepare_model() and register_and_write()
// on the phantom 'standard', checked against the command line on the same inputs — the model the
// CLI prepares is the same size, and the CLI's registration of the library's model gives the same
// TRE (brainshift evaluate on both result folders). One test: the phantom takes ≈ 10 s.

#include "apps/cli_helpers.hpp"
#include "apps/workflow/prepare.hpp"
#include "apps/workflow/progress.hpp"
#include "apps/workflow/register.hpp"
#include "data_synth/cases/phantom_case.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <string>

namespace brainshift {
namespace {

nlohmann::json read_json(const std::filesystem::path& p) {
  return nlohmann::json::parse(read_all(p));
}

TEST(WorkflowApi, PrepareAndRegisterMatchTheCommandLine) {
  const tests::TempFolder dir;
  const auto ph = dir / "phantom";
  data_synth::CaseOptions co;
  co.out = ph;
  (void)data_synth::generate_case("standard", 1, co);

  // prepare: library and command line on the same inputs.
  workflow::PrepareOptions po;
  po.labels = ph / "preop/labels.nii.gz";
  po.mra = ph / "preop/mra.nii.gz";
  po.out = dir / "model_api";
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

}  // namespace
}  // namespace brainshift
