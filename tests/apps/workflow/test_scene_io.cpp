#include "expect_error.hpp"
#include "temp_folder.hpp"

#include "apps/workflow/scene_io.hpp"
#include "core/mesh/boundary.hpp"
#include "data_synth/geometry/structured_mesh.hpp"
#include "imaging/io/mesh_io.hpp"
#include "imaging/io/skeleton_io.hpp"
#include "imaging/io/surface_io.hpp"

#include <gtest/gtest.h>

#include <fstream>
#include <string>

namespace brainshift::workflow {
namespace {

using imaging::read_surface_vtp;
using imaging::VesselGraph;
using imaging::write_skeleton_vtp;
using imaging::write_surface_vtp;
using imaging::write_tet_mesh;
using tests::expect_error;

/// A folder with mesh.vtu, surface.vtp (its boundary) and vessels.vtp (one 3-point branch).
struct SceneFolder {
  tests::TempFolder dir;
  core::TetMesh mesh = data_synth::make_box_mesh({40, 40, 40}, {4, 4, 4}, {-20, -20, -20});
  SceneFolder() {
    write_tet_mesh(dir / "mesh.vtu", mesh);
    const core::BoundarySurface b = core::boundary_surface(mesh);
    write_surface_vtp(dir / "surface.vtp", core::SurfaceMesh{b.vertices, b.faces});
    VesselGraph g;
    g.nodes = {{Vector3d(-10, 0, 5), 1.0}, {Vector3d(10, 0, 5), 0.8}};
    g.branches = {
        {0, 1, {Vector3d(-10, 0, 5), Vector3d(0, 2, 5), Vector3d(10, 0, 5)}, {1.0, 0.9, 0.8}}};
    write_skeleton_vtp(dir / "vessels.vtp", g);
  }
  std::filesystem::path scene(const std::string& json) const {
    const auto p = dir / "scene.json";
    std::ofstream(p) << json;
    return p;
  }
};

TEST(SceneIo, ReadsEveryPartAndSetting) {
  SceneFolder f;
  const Scene s = read_scene(f.scene(R"({
    "version": 1, "mesh": "mesh.vtu", "collision_surface": "surface.vtp", "vessels": "vessels.vtp",
    "materials": {"youngs_modulus_kpa": 3.0},
    "fixed": {"below": {"direction": [0, 0, -1], "height_mm": 1}},
    "craniotomy": {"centre_mm": [0, 0, 20], "radius_mm": 12},
    "constraints": {"vessels": true, "footprint": false, "dura": "unilateral"},
    "start": "identity",
    "pairing": {"max_distance_mm": 9},
    "filter": {"vessels": {"max_per_tet": 3, "max_angle_deg": 30}},
    "solver": {"max_iterations": 12, "trust_region_mm": 2.5, "constraint_solver": "gauss_seidel",
               "compliance": {"vessels": 0.5}, "compliance_budget_mib": 64}
  })"));
  EXPECT_EQ(s.mesh.num_nodes(), 125);
  EXPECT_EQ(s.mesh.youngs_modulus().minCoeff(), 3.0);
  EXPECT_EQ(s.mesh.poisson_ratio().maxCoeff(), 0.45);  // untouched default
  EXPECT_EQ(s.fixed_nodes.size(), 25u);  // the bottom layer z = −20 of a 5×5×5 grid
  EXPECT_EQ(s.surface.triangles.rows(), 2 * 6 * 16);
  EXPECT_EQ(s.skeleton.points.rows(), 3);
  EXPECT_EQ(s.skeleton.segments.size(), 2u);
  const auto& o = s.options;
  EXPECT_FALSE(o.use_footprint);
  EXPECT_EQ(o.dura.mode, constraints::DuraOptions::Mode::UNILATERAL);
  EXPECT_EQ(o.dura.craniotomy_radius_mm, 12.0);
  EXPECT_EQ(o.start, constraints::RigidStart::IDENTITY);
  EXPECT_EQ(o.pair_max_distance_mm, 9.0);
  EXPECT_EQ(o.vessel_filter.max_per_tet, 3);
  EXPECT_EQ(o.vessel_filter.max_angle_deg, 30.0);
  EXPECT_EQ(o.max_iterations, 12);
  EXPECT_EQ(o.step.max_increment, 2.5);
  EXPECT_EQ(o.step.solver, constraints::ConstraintSolver::GAUSS_SEIDEL);
  EXPECT_EQ(o.step.compliance_ratio[0], 0.5);
  EXPECT_EQ(s.compliance.memory_budget_bytes, std::size_t{64} << 20);
}

TEST(SceneIo, OnlyTheMeshIsRequiredAndNothingElseIsBuilt) {
  SceneFolder f;
  const Scene s = read_scene(f.scene(R"({"mesh": "mesh.vtu"})"));
  EXPECT_EQ(s.skeleton.points.rows(), 0);
  EXPECT_EQ(s.surface.triangles.rows(), 0);
  EXPECT_EQ(s.fixed_nodes.size(),
            50u);  // default: within 15 mm of the lowest node along −z: z = −20, −10
  EXPECT_EQ(s.options.dura.mode, constraints::DuraOptions::Mode::NONE);
}

TEST(SceneIo, BadScenesGiveOneLineErrorsNamingFileAndKey) {
  SceneFolder f;
  expect_error([&] { read_scene(f.dir / "none.json"); }, {"none.json", "cannot open"});
  expect_error([&] { read_scene(f.scene("{ not json")); }, {"scene.json", "not valid JSON"});
  expect_error([&] { read_scene(f.scene(R"({"vessels": "vessels.vtp"})")); },
               {"scene.json", "missing key 'mesh'"});
  expect_error([&] { read_scene(f.scene(R"({"mesh": "mesh.vtu", "mesh_size": 3})")); },
               {"scene.json", "unknown key 'mesh_size'"});
  expect_error([&] { read_scene(f.scene(R"({"mesh": "mesh.vtu", "solver": {"pgs_tol": 1e-3}})")); },
               {"unknown key 'solver.pgs_tol'", "pgs_tolerance"});
  expect_error([&] { read_scene(f.scene(R"({"mesh": "missing.vtu"})")); },
               {"scene.json", "'mesh'", "missing.vtu"});
  expect_error([&] { read_scene(f.scene(R"({"mesh": "mesh.vtu", "vessels": "surface.vtp"})")); },
               {"'vessels'", "surface.vtp", "no line cells"});
  expect_error(
      [&] { read_scene(f.scene(R"({"mesh": "mesh.vtu", "craniotomy": {"radius_mm": "big"}})")); },
      {"'craniotomy.radius_mm' must be a number"});
  expect_error(
      [&] { read_scene(f.scene(R"({"mesh": "mesh.vtu", "craniotomy": {"radius_mm": -3}})")); },
      {"'craniotomy.radius_mm' = -3mm is out of range"});
  expect_error(
      [&] { read_scene(f.scene(R"({"mesh": "mesh.vtu", "constraints": {"dura": "sticky"}})")); },
      {"'constraints.dura' = \"sticky\" is not one of"});
  expect_error(
      [&] { read_scene(f.scene(R"({"mesh": "mesh.vtu", "constraints": {"dura": "sliding"}})")); },
      {"dura contact needs a 'collision_surface'"});
  expect_error(
      [&] {
        read_scene(f.scene(
            R"({"mesh": "mesh.vtu", "fixed": {"below": {"height_mm": 1, "direction": [0, 0, 0]}}})"));
      },
      {"down direction must be non-zero"});
  expect_error(
      [&] { read_scene(f.scene(R"({"mesh": "mesh.vtu", "materials": {"poisson_ratio": 0.5}})")); },
      {"'materials.poisson_ratio'", "out of range"});
}

TEST(SceneIo, EveryOptionIsSettableFromTheSceneAndTheOldSpellingIsRejected) {
  SceneFolder f;
  // Options that only a recompilation could change before the tables (issue 17).
  const Scene s = read_scene(f.scene(R"({
    "mesh": "mesh.vtu",
    "shift_search": {"radius_mm": 30, "enabled": false},
    "pairing": {"refine_distance_mm": 1.5},
    "global_start": {"max_translation_mm": 40, "bulk_response": false},
    "noise": {"enabled": true, "paired_test_z": 3},
    "acceptance": {"min_vessel_pairs": 7},
    "solver": {"pgs_max_iterations": 50, "compliance_strategy": "sparse_solve", "cold_retry": false},
    "craniotomy": {"centre_mm": [1, 2, 3]}
  })"));
  const auto& o = s.options;
  EXPECT_EQ(o.global_start.bulk_search.radius_mm, 30.0);
  EXPECT_FALSE(o.global_start.bulk_search.enabled);
  EXPECT_EQ(o.refine_pair_distance_mm, 1.5);
  EXPECT_EQ(o.global_start.max_translation_mm, 40.0);
  EXPECT_FALSE(o.global_start.bulk_response);
  EXPECT_TRUE(o.noise.enabled);
  EXPECT_EQ(o.noise.paired_test_z, 3.0);
  EXPECT_EQ(o.min_vessel_pairs, 7);
  EXPECT_EQ(o.step.pgs.max_iterations, 50);
  EXPECT_EQ(s.compliance.strategy, constraints::ComplianceStrategy::SPARSE_SOLVE);
  EXPECT_FALSE(o.cold_retry);
  EXPECT_EQ(o.dura.craniotomy_centre, Vector3d(1, 2, 3));
  // The old spelling is an error with the new one, not silently ignored.
  expect_error(
      [&] {
        read_scene(f.scene(R"({"mesh": "mesh.vtu", "craniotomy": {"center_mm": [0, 0, 1]}})"));
      },
      {"scene.json", "'craniotomy.center_mm' is spelled 'craniotomy.centre_mm'"});
  // A value the table accepts but validate() does not (fine kernel wider than the coarse one).
  expect_error(
      [&] {
        read_scene(f.scene(R"({"mesh": "mesh.vtu", "global_start": {"fine_kernel_mm": 9}})"));
      },
      {"scene.json", "fine_kernel_mm"});
  EXPECT_TRUE(scene_option_keys().count("noise"));
  EXPECT_FALSE(scene_option_keys().count("mesh"));
}

TEST(SurfaceIo, RoundTripsExactlyAndRejectsNonTriangles) {
  SceneFolder f;
  const core::SurfaceMesh s = read_surface_vtp(f.dir / "surface.vtp");
  const core::BoundarySurface b = core::boundary_surface(f.mesh);
  EXPECT_EQ(s.vertices, b.vertices);
  EXPECT_EQ(s.triangles, b.faces);
  expect_error([&] { read_surface_vtp(f.dir / "vessels.vtp"); }, {"vessels.vtp", "no triangles"});
  expect_error([&] { read_surface_vtp(f.dir / "nothing.vtp"); }, {"nothing.vtp", "no such file"});
  core::SurfaceMesh bad = s;
  bad.triangles(0, 0) = 100000;
  expect_error([&] { write_surface_vtp(f.dir / "bad.vtp", bad); }, {"bad.vtp", "indexes a vertex"});
  EXPECT_FALSE(std::filesystem::exists(f.dir / "bad.vtp"));
}

}  // namespace
}  // namespace brainshift::workflow
