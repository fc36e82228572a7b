// `brainshift prepare --scene-options FILE` (issue 17 item 3): a file of option overrides is
// merged into the scene prepare writes; an unknown key, or the old spelling `center`, is a
// one-line error naming the file and the key before anything is meshed, and nothing is written.

#include "../cli_helpers.hpp"

#include "apps/workflow/scene_io.hpp"
#include "imaging/io/csv.hpp"
#include "imaging/io/image_io.hpp"
#include "imaging/io/mesh_io.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <string>

namespace brainshift {
namespace {

/// A 20 mm brain ball (34 mL, label 1) and an MRA with one 2 mm tube through it along x.
struct BallInputs {
  tests::TempFolder dir;
  std::filesystem::path labels = dir / "ball.nii.gz";
  std::filesystem::path mra = dir / "mra.nii.gz";
  BallInputs() {
    imaging::ImageGeometry g;
    g.size = Eigen::Vector3i::Constant(26);
    g.spacing = Vector3d::Constant(2.0);
    g.origin = Vector3d::Constant(-25.0);
    imaging::LabelVolume l(g);
    imaging::VolumeF m(g);
    for (int k = 0; k < g.size[2]; ++k)
      for (int j = 0; j < g.size[1]; ++j)
        for (int i = 0; i < g.size[0]; ++i) {
          const Vector3d p = g.index_to_world(Vector3d(i, j, k));
          l.at(i, j, k) = p.norm() < 20.0 ? 1 : 0;
          const double d = Eigen::Vector2d(p.y(), p.z() - 8.0).norm();
          m.at(i, j, k) = float(60.0 + 240.0 * std::clamp(3.0 - d, 0.0, 1.0));
        }
    imaging::write_labels(labels, l);
    imaging::write_volume(mra, m);
  }
  [[nodiscard]] CliRun prepare(const std::string& options_json,
                               const std::filesystem::path& out) const {
    const auto options = dir / "options.json";
    std::ofstream(options) << options_json;
    return run_brainshift(dir, "prepare --labels " + q(labels) + " --mra " + q(mra) +
                                   " --scene-options " + q(options) + " --out " + q(out));
  }
};

TEST(PrepareSceneOptions, AGoodFileIsMergedIntoTheScene) {
  const BallInputs in;
  const auto out = in.dir / "model";
  const CliRun r = in.prepare(
      R"({"solver": {"max_iterations": 33, "pgs_tolerance": 1e-5},
          "shift_search": {"radius_mm": 25}, "noise": {"paired_test_z": 3}})",
      out);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::ifstream scene_file(out / "scene.json");
  const nlohmann::json scene = nlohmann::json::parse(scene_file);
  // The overrides are in the scene as given, beside prepare's own keys.
  EXPECT_EQ(scene["solver"]["max_iterations"], 33);
  EXPECT_EQ(scene["solver"]["pgs_tolerance"], 1e-5);
  EXPECT_EQ(scene["shift_search"]["radius_mm"], 25);
  EXPECT_EQ(scene["noise"]["paired_test_z"], 3);
  EXPECT_EQ(scene["mesh"], "mesh.vtu");
  EXPECT_TRUE(scene["craniotomy"].contains("centre_mm"));
}

TEST(PrepareSceneOptions, AFixedRegionGivenReplacesPreparesAndFixedCsvHoldsItsNodes) {
  // The scene's two forms of the fixed region, 'nodes' (prepare's fixed.csv) and 'below', are
  // alternatives: a 'below' given must replace prepare's 'nodes', not sit beside it (a merge
  // did, and the model was refused: "'fixed' needs exactly one of 'nodes' or 'below'").
  const BallInputs in;
  const auto out = in.dir / "model";
  const CliRun r = in.prepare(R"({"fixed": {"below": {"height_mm": 12}}})", out);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::ifstream scene_file(out / "scene.json");
  const nlohmann::json scene = nlohmann::json::parse(scene_file);
  EXPECT_EQ(scene["fixed"], nlohmann::json::parse(R"({"below": {"height_mm": 12}})"));
  std::ifstream manifest_file(out / "model.json");
  const nlohmann::json manifest = nlohmann::json::parse(manifest_file);
  EXPECT_EQ(manifest["fixed"]["rule"], "given by --scene-options");
  // fixed.csv lists the nodes the model is fixed at: the scene's slab (every node within 12 mm of
  // the lowest along −z), not prepare's own region (the 15 mm floor's boundary nodes).
  const core::TetMesh mesh = imaging::read_tet_mesh(out / "mesh.vtu");
  const std::vector<index_t> expected = workflow::nodes_below(mesh, Vector3d(0, 0, -1), 12.0);
  EXPECT_GE(expected.size(), 3u);
  EXPECT_EQ(imaging::read_node_list(out / "fixed.csv", mesh.num_nodes()), expected);
}

TEST(PrepareSceneOptions, AnUnknownKeyOrTheOldSpellingIsAOneLineErrorAndNothingIsWritten) {
  const BallInputs in;
  const auto out = in.dir / "model";
  {
    const CliRun r = in.prepare(R"({"solver": {"pgs_tol": 1e-3}})", out);
    expect_one_line_error(r, "options.json: unknown key 'solver.pgs_tol' (known here: ");
    expect_one_line_error(r, "pgs_tolerance");  // the known keys of that object are listed
    EXPECT_EQ(r.err.find("meshing"), std::string::npos);  // refused before the meshing
    EXPECT_FALSE(std::filesystem::exists(out));
  }
  {
    const CliRun r = in.prepare(R"({"craniotomy": {"center_mm": [0, 0, 20]}})", out);
    expect_one_line_error(r,
                          "options.json: 'craniotomy.center_mm' is spelled "
                          "'craniotomy.centre_mm'");
    EXPECT_FALSE(std::filesystem::exists(out));
  }
  {
    const CliRun r = in.prepare(R"({"noise": {"grid": 1}})", out);
    expect_one_line_error(r, "options.json: 'noise.grid' = 1 is out of range [2, 10000]");
    EXPECT_FALSE(std::filesystem::exists(out));
  }
}

}  // namespace
}  // namespace brainshift
