// Drives the real `brainshift` executable: exit codes, one-line error messages naming the bad
// file, no partial output, and results that honour the prescribed displacements.

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "core/solver/static_solver.hpp"
#include "data_synth/geometry/structured_mesh.hpp"
#include "imaging/io/csv.hpp"
#include "imaging/io/mesh_io.hpp"
#include "temp_folder.hpp"
#include "tests/config.hpp"

namespace brainshift {
namespace {

struct CliRun {
  int exit_code = -1;
  std::string out;
  std::string err;
};

std::string read_all(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

/// Runs `brainshift <args>` with stdout and stderr captured in files of `dir`.
CliRun run_brainshift(const tests::TempFolder& dir, const std::string& args) {
  const auto out = dir.path().parent_path() / (dir.path().filename().string() + ".stdout");
  const auto err = dir.path().parent_path() / (dir.path().filename().string() + ".stderr");
  const std::string command = std::string("'") + tests::brainshift_exe + "' " + args + " >'" +
                              out.string() + "' 2>'" + err.string() + "'";
  const int status = std::system(command.c_str());
  CliRun r;
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.out = read_all(out);
  r.err = read_all(err);
  std::filesystem::remove(out);
  std::filesystem::remove(err);
  return r;
}

/// Prescribed values may pass through x = X + u and back: a few ulps of 80 mm coordinates.
constexpr double dirichlet_tol = 1e-12;

/// `p` in single quotes for the shell (built by appending: GCC 12 warns falsely, -Wrestrict,
/// on "literal" + std::string).
std::string q(const std::filesystem::path& p) {
  std::string s = "'";
  s += p.string();
  s += '\'';
  return s;
}

/// The error contract: non-zero exit, exactly one line on stderr, prefixed, containing `needle`.
void expect_one_line_error(const CliRun& r, const std::string& needle) {
  EXPECT_NE(r.exit_code, 0);
  EXPECT_EQ(r.err.rfind("brainshift: error: ", 0), 0u) << r.err;
  ASSERT_FALSE(r.err.empty());
  EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << "not one line:\n" << r.err;
  EXPECT_NE(r.err.find(needle), std::string::npos) << r.err;
}

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
  const CliRun r = run_brainshift(dir, inputs() + " --linear --gravity 0,0,-9810 --out " +
                                        q(dir / "result.vtu"));
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
  const CliRun r = run_brainshift(dir, "simulate --mesh " + q(dir / "mesh.vtu") + " --out " +
                                        q(dir / "result.vtu"));
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

TEST(Cli, DemoWritesItsInputsAndAResultWithTheTopMoved) {
  const tests::TempFolder dir;
  const auto out = dir / "demo";
  const CliRun r = run_brainshift(dir, "demo --out " + q(out));
  for (const char* f : {"mesh.vtu", "fixed.csv", "displace.csv"})
    EXPECT_TRUE(std::filesystem::exists(out / f)) << f;
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  const core::TetMesh mesh = imaging::read_tet_mesh(out / "mesh.vtu");
  EXPECT_GT(mesh.num_nodes(), 1500);
  EXPECT_LT(mesh.num_nodes(), 2500);
  const MatrixX3d u = imaging::read_displacement(out / "result.vtu");
  for (const auto& p : imaging::read_node_displacements(out / "displace.csv")) {
    EXPECT_LT((u.row(p.node).transpose() - Vector3d(10, 0, 0)).norm(), dirichlet_tol);
  }
  for (const index_t n : imaging::read_node_list(out / "fixed.csv")) {
    EXPECT_LT(u.row(n).norm(), dirichlet_tol);
  }
}

}  // namespace
}  // namespace brainshift
