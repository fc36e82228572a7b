// Drives the real `brainshift` executable: exit codes, one-line error messages naming the bad
// file, no partial output, and results that honour the prescribed displacements.

#include "cli_helpers.hpp"
#include "temp_folder.hpp"
#include "tests/config.hpp"

#include "core/solver/static_solver.hpp"
#include "data_synth/geometry/structured_mesh.hpp"
#include "imaging/io/csv.hpp"
#include "imaging/io/mesh_io.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <sys/wait.h>
#include <vector>

namespace brainshift {
namespace {

/// Prescribed values may pass through x = X + u and back: a few ulps of 80 mm coordinates.
constexpr double dirichlet_tol = 1e-12;

/// A 20×20×40 mm box (3×3×6 cells) with its bottom fixed and its top moved by `top` (mm).
class SimulateBox : public ::testing::Test {
 protected:
  void SetUp() override {
    mesh = data_synth::make_box_mesh({20, 20, 40}, {3, 3, 6});
    for (index_t i = 0; i < mesh.num_nodes(); ++i) {
      if (mesh.nodes()(i, 2) == 0.0) bottom.push_back(i);
      if (mesh.nodes()(i, 2) == 40.0) top.push_back({i, top_displacement});
    }
    imaging::write_tet_mesh(dir / "mesh.vtu", mesh);
    imaging::write_node_list(dir / "fixed.csv", bottom);
    imaging::write_node_displacements(dir / "displace.csv", top);
  }
  [[nodiscard]] std::string inputs() const {
    return "simulate --mesh " + q(dir / "mesh.vtu") + " --fixed " + q(dir / "fixed.csv") +
           " --displace " + q(dir / "displace.csv");
  }

  const Vector3d top_displacement{1.0, 0.5, -0.5};  // mm: small, converges in a few iterations
  const tests::TempFolder dir;
  core::TetMesh mesh;
  std::vector<index_t> bottom;
  std::vector<core::PrescribedDisplacement> top;
};

TEST_F(SimulateBox, WritesTheDisplacementWithTheTopMovedAsPrescribed) {
  const auto result = dir / "result.vtu";
  const CliRun r = run_brainshift(dir, inputs() + " --out " + q(result));
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_TRUE(r.err.empty()) << r.err;
  for (const char* word : {"converged", "iterations", "final increment", "final residual",
                           "inverted elements", "wall time"}) {
    EXPECT_NE(r.out.find(word), std::string::npos) << word << " missing in:\n" << r.out;
  }
  // The result holds the rest mesh unchanged and the displacement array.
  const core::TetMesh back = imaging::read_tet_mesh(result);
  EXPECT_EQ(back.nodes(), mesh.nodes());
  EXPECT_EQ(back.tets(), mesh.tets());
  const MatrixX3d u = imaging::read_displacement(result);
  ASSERT_EQ(u.rows(), mesh.num_nodes());
  // Dirichlet values are imposed, not solved for: only the rounding of (X + u) − X remains.
  for (const auto& p : top) {
    EXPECT_LT((u.row(p.node).transpose() - top_displacement).norm(), dirichlet_tol) << p.node;
  }
  for (const index_t n : bottom) EXPECT_LT(u.row(n).norm(), dirichlet_tol) << n;
  EXPECT_TRUE(u.allFinite());
}

TEST_F(SimulateBox, LinearAndGravityOptionsRun) {
  const CliRun r = run_brainshift(
      dir, inputs() + " --linear --gravity 0,0,-9810 --out " + q(dir / "result.vtu"));
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("linear"), std::string::npos) << r.out;
  const CliRun bad = run_brainshift(dir, inputs() + " --gravity 0,0 --out " + q(dir / "r2.vtu"));
  EXPECT_NE(bad.exit_code, 0);
  EXPECT_FALSE(std::filesystem::exists(dir / "r2.vtu"));
}

TEST_F(SimulateBox, MissingMeshIsNamedAndNothingIsWritten) {
  const auto out = dir / "result.vtu";
  const CliRun r = run_brainshift(dir, "simulate --mesh " + q(dir / "nope.vtu") + " --fixed " +
                                           q(dir / "fixed.csv") + " --out " + q(out));
  expect_one_line_error(r, (dir / "nope.vtu").string());
  EXPECT_EQ(dir.count(), 3u);  // the three inputs only
}

TEST_F(SimulateBox, BadCsvLineIsNamedAndNothingIsWritten) {
  std::ofstream(dir / "fixed.csv") << "node\n0\n1\nabc\n";
  const CliRun r = run_brainshift(dir, inputs() + " --out " + q(dir / "result.vtu"));
  expect_one_line_error(r, (dir / "fixed.csv").string() + ":4");
  EXPECT_EQ(dir.count(), 3u);
}

TEST_F(SimulateBox, NodeIdOutOfRangeIsNamedAndNothingIsWritten) {
  std::ofstream(dir / "displace.csv") << "node,dx,dy,dz\n" << mesh.num_nodes() << ",1,0,0\n";
  const CliRun r = run_brainshift(dir, inputs() + " --out " + q(dir / "result.vtu"));
  expect_one_line_error(r, (dir / "displace.csv").string() + ":2");
  EXPECT_NE(r.err.find("out of range"), std::string::npos) << r.err;
  EXPECT_EQ(dir.count(), 3u);
}

TEST_F(SimulateBox, UnwritableOutputFolderIsNamed) {
  const auto out = dir / "no_such_folder" / "result.vtu";
  const CliRun r = run_brainshift(dir, inputs() + " --out " + q(out));
  expect_one_line_error(r, out.string());
  EXPECT_EQ(dir.count(), 3u);
}

TEST_F(SimulateBox, NoDirichletNodesIsAClearError) {
  const CliRun r = run_brainshift(
      dir, "simulate --mesh " + q(dir / "mesh.vtu") + " --out " + q(dir / "result.vtu"));
  expect_one_line_error(r, "--fixed");
  EXPECT_EQ(dir.count(), 3u);
}

TEST_F(SimulateBox, NodeBothFixedAndDisplacedIsAnError) {
  std::ofstream(dir / "fixed.csv") << "node\n" << top.front().node << '\n';
  const CliRun r = run_brainshift(dir, inputs() + " --out " + q(dir / "result.vtu"));
  expect_one_line_error(r, "both fixed");
}

TEST_F(SimulateBox, NonConvergenceExitsWithTwoAndWritesOnlyOnRequest) {
  // One corotational iteration cannot reach the tolerance for a finite rotation.
  const std::string args = inputs() + " --max-iterations 1 --out " + q(dir / "result.vtu");
  const CliRun r = run_brainshift(dir, args);
  EXPECT_EQ(r.exit_code, 2) << r.out << r.err;
  expect_one_line_error(r, "did not converge");
  EXPECT_FALSE(std::filesystem::exists(dir / "result.vtu"));
  const CliRun forced = run_brainshift(dir, args + " --write-unconverged");
  EXPECT_EQ(forced.exit_code, 2);
  EXPECT_TRUE(std::filesystem::exists(dir / "result.vtu"));
}

TEST(Cli, HelpWorksForEverySubcommand) {
  const tests::TempFolder dir;
  const CliRun top = run_brainshift(dir, "--help");
  EXPECT_EQ(top.exit_code, 0);
  EXPECT_NE(top.out.find("simulate"), std::string::npos) << top.out;
  EXPECT_NE(top.out.find("demo"), std::string::npos) << top.out;
  const CliRun sim = run_brainshift(dir, "simulate --help");
  EXPECT_EQ(sim.exit_code, 0);
  for (const char* opt : {"--mesh", "--fixed", "--displace", "--gravity", "--linear",
                          "--max-iterations", "--tolerance", "--out"}) {
    EXPECT_NE(sim.out.find(opt), std::string::npos) << opt << " missing in:\n" << sim.out;
  }
  const CliRun demo = run_brainshift(dir, "demo --help");
  EXPECT_EQ(demo.exit_code, 0);
  EXPECT_NE(demo.out.find("--out"), std::string::npos) << demo.out;
}

TEST(Cli, SyntaxErrorsAreOneLine) {
  const tests::TempFolder dir;
  expect_one_line_error(run_brainshift(dir, ""), "subcommand");
  expect_one_line_error(run_brainshift(dir, "simulate --mesh m.vtu"), "--out");
  expect_one_line_error(run_brainshift(dir, "frobnicate"), "subcommand");
}

TEST(Cli, DemoRunsTheWholeWorkflowAndCorrectsMostOfTheShift) {
  const tests::TempFolder dir;
  const auto out = dir / "demo";
  const CliRun r = run_brainshift(dir, "demo --out " + q(out));
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  for (const char* f :
       {"report.json", "evaluation.json", "deformed.vtu", "displacement.nii.gz",
        "preop_to_intraop.nrrd", "intraop_to_preop.nrrd", "warped_mri.nii.gz", "overlay.png"})
    EXPECT_TRUE(std::filesystem::exists(out / "result" / f)) << f;
  EXPECT_TRUE(std::filesystem::exists(out / "pre_dura_pose.json"));
  EXPECT_TRUE(std::filesystem::exists(out / "result_one_sweep" / "evaluation.json"));
  for (const char* k : {"two sweeps", "one sweep", "whole brain", "max deformation"})
    EXPECT_NE(r.out.find(k), std::string::npos) << k << "\n" << r.out;
  // The demo's main path is the surgical session: the pose measured on the sweep over the closed
  // dura, stored, and given to the sweep after opening.
  const auto report = nlohmann::json::parse(read_all(out / "result" / "report.json"));
  EXPECT_EQ(report["intraop"]["pre_dura"]["source"], "pose_file") << report["intraop"].dump();
  const auto ev = nlohmann::json::parse(read_all(out / "result" / "evaluation.json"));
  // The phantom's mean landmark shift is ≈ 7 mm; the registration must remove at least half of
  // it (measured on seed 1: 7.23 → 0.99 mm, 86 %).
  EXPECT_GT(ev["tre_before_mm"]["mean"].get<double>(), 5.0);
  EXPECT_LT(ev["tre_after_mm"]["mean"].get<double>(),
            0.5 * ev["tre_before_mm"]["mean"].get<double>());
  EXPECT_GT(ev["shift_corrected_pct"].get<double>(), 50.0);
  // Over the whole brain (2000 points of the phantom's own truth field, a neo-Hookean model on
  // its own mesh, not ours) the two-sweep result meets issue 32's bar: ≤ 1.2 mm mean on
  // `standard` (measured 4.16 → 1.13 mm; the true pose, the identity, gives 1.13 too; before the
  // pose's significance test the pre-dura sweep's 3° tilt gave 2.69; one sweep alone 9.32).
  ASSERT_TRUE(ev.contains("whole_brain_after_mm")) << ev.dump();
  EXPECT_GE(ev["whole_brain_points"].get<int>(), 1000);
  EXPECT_LE(ev["whole_brain_after_mm"]["mean"].get<double>(), 1.2)
      << ev["whole_brain_after_mm"].dump();
  // A visible deformation: the model's own, not the rigid start alone (measured 15.7 mm; the
  // phantom's cortical shift is 10 mm at most).
  EXPECT_GT(report["max_displacement_mm"].get<double>(), 3.0);
  // The phantom's navigation is exact (the identity), so any motion of the fixed base by the pose
  // is error. The two-sweep result keeps the base (the pre-dura pose is the identity here); the
  // one-sweep pose takes the sag and tilts the whole brain (measured 15.1 mm on average at the
  // base, whole brain 9.32 mm): its report must say so, beyond RESECT's 6.6 mm accuracy.
  EXPECT_LT(report["rigid"]["fixed_base_moved_mm"]["mean"].get<double>(), 1.0);
  EXPECT_EQ(report["rigid"]["fixed_base_moved_mm"]["note"], "");
  const auto one = nlohmann::json::parse(read_all(out / "result_one_sweep" / "report.json"));
  EXPECT_GT(one["rigid"]["fixed_base_moved_mm"]["mean"].get<double>(), 6.6);
  EXPECT_NE(one["rigid"]["fixed_base_moved_mm"]["note"].get<std::string>().find("pre-dura"),
            std::string::npos);
  EXPECT_NE(r.out.find("the pose moves the fixed base"), std::string::npos) << r.out;
}

}  // namespace
}  // namespace brainshift
