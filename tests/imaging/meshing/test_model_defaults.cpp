#include "expect_error.hpp"

#include "core/mapping/tet_locator.hpp"
#include "data_synth/geometry/structured_mesh.hpp"
#include "imaging/meshing/model_defaults.hpp"
#include "imaging/meshing/skeleton_in_mesh.hpp"

#include <gtest/gtest.h>

#include <vector>

namespace brainshift::imaging {
namespace {

using tests::expect_error;

TEST(DefaultFixedRegion, IsFifteenMillimetresOnSmallBrainsAndThirtyPercentOnTallOnes) {
  // 30 mm tall: 30 % is 9 mm, so the 15 mm floor holds (node planes z = 0, 7.5, 15, ...).
  const core::TetMesh short_box =
      data_synth::make_box_mesh(Vector3d(10, 20, 30), Eigen::Vector3i(2, 3, 4));
  const FixedRegion a = default_fixed_region(outer_boundary_surface(short_box));
  EXPECT_DOUBLE_EQ(a.extent_mm, 30.0);
  EXPECT_DOUBLE_EQ(a.height_mm, 15.0);
  EXPECT_EQ(a.nodes,
            fixed_region_nodes(outer_boundary_surface(short_box), Vector3d(0, 0, -1), 15.0));
  // 160 mm tall (an adult brain from the brain stem's end to the vertex is 150-155 mm): 48 mm.
  // Node planes every 5 mm, so none lies at the slab's top.
  const core::TetMesh tall_box =
      data_synth::make_box_mesh(Vector3d(10, 20, 160), Eigen::Vector3i(2, 2, 32));
  const FixedRegion b = default_fixed_region(outer_boundary_surface(tall_box));
  EXPECT_NEAR(b.height_mm, 48.0, 1e-9);
  for (index_t n : b.nodes) EXPECT_LE(tall_box.nodes()(n, 2), 48.0);
  EXPECT_EQ(b.nodes.size(),
            3u * 3u + 9u * 8u);  // the bottom plane, then 9 planes of 8 rim nodes (z = 5 … 45)
  EXPECT_NE(b.rule.find("48 mm"), std::string::npos) << b.rule;
  expect_error(
      [&] { (void)default_fixed_region(outer_boundary_surface(tall_box), Vector3d::Zero()); },
      {"down direction"});
}

TEST(DefaultCraniotomy, IsOverTheTumourWhenThereIsOneElseAtTheTop) {
  const core::TetMesh ball = data_synth::make_ellipsoid_mesh(Vector3d(70, 85, 60), /*cells=*/12);
  const core::SurfaceMesh surface = outer_boundary_surface(ball).surface;
  // No tumour: the highest surface point.
  const Craniotomy top = default_craniotomy(surface, ball, {});
  EXPECT_DOUBLE_EQ(top.centre.z(), surface.vertices.col(2).maxCoeff());
  EXPECT_DOUBLE_EQ(top.radius_mm, 30.0);
  // Tumour tetrahedra around (40, 30, 20): the nearest surface vertex to their centroid, which
  // lies on the right-anterior-superior side, not at the top.
  std::vector<std::uint8_t> label(std::size_t(ball.num_tets()), BRAIN);
  for (index_t t = 0; t < ball.num_tets(); ++t) {
    Vector3d c = Vector3d::Zero();
    for (int k = 0; k < 4; ++k) c += ball.nodes().row(ball.tets()(t, k)).transpose() / 4.0;
    if ((c - Vector3d(40, 30, 20)).norm() < 12.0) label[std::size_t(t)] = TUMOUR;
  }
  const Craniotomy over = default_craniotomy(surface, ball, label);
  Eigen::Index nearest = 0;
  (surface.vertices.rowwise() - Eigen::RowVector3d(40, 30, 20))
      .rowwise()
      .squaredNorm()
      .minCoeff(&nearest);
  // The tumour's centroid is within a tetrahedron of (40, 30, 20), so the chosen vertex is the
  // nearest one to that point or a neighbour: within one surface edge (≈ 12 mm) of it.
  EXPECT_LE((over.centre - surface.vertices.row(nearest).transpose()).norm(), 12.0);
  EXPECT_GT(over.centre.x(), 30.0);
  EXPECT_NE(over.rule.find("tumour"), std::string::npos) << over.rule;
  expect_error(
      [&] { (void)default_craniotomy(surface, ball, std::vector<std::uint8_t>(3, BRAIN)); },
      {"labels"});
}

/// A straight branch of `n` points from a to b, radius 1 mm, between two new nodes.
void add_branch(VesselGraph& g, const Vector3d& a, const Vector3d& b, int n) {
  VesselGraph::Branch br;
  for (int i = 0; i < n; ++i) {
    br.points.push_back(a + (b - a) * double(i) / double(n - 1));
    br.radius.push_back(1.0);
  }
  g.nodes.push_back({a, 1.0});
  g.nodes.push_back({b, 1.0});
  br.from = index_t(g.nodes.size() - 2);
  br.to = index_t(g.nodes.size() - 1);
  g.branches.push_back(br);
}

TEST(SkeletonInMesh, KeepsInsidePointsSnapsNearOnesAndDropsFarOnes) {
  const core::TetMesh box =
      data_synth::make_box_mesh(Vector3d(40, 40, 40), Eigen::Vector3i(4, 4, 4));
  VesselGraph g;
  add_branch(g, Vector3d(5, 20, 20), Vector3d(35, 20, 20), 7);  // inside
  add_branch(g, Vector3d(5, 10, 43), Vector3d(35, 10, 43), 7);  // 3 mm above the top: snapped
  add_branch(g, Vector3d(5, 30, 48), Vector3d(35, 30, 48), 7);  // 8 mm above: dropped
  // Rising from inside to 10 mm out: z = 30, 34, …, 50 → kept up to 44 (4 mm out), then dropped.
  add_branch(g, Vector3d(20, 5, 30), Vector3d(20, 5, 50), 6);
  const SkeletonFit fit = fit_skeleton_to_mesh(g, box, /*snap_distance_mm=*/5.0);
  EXPECT_EQ(fit.points, 27);
  EXPECT_EQ(fit.inside, 7 + 3);   // the first branch, z = 30, 34, 38 of the last
  EXPECT_EQ(fit.snapped, 7 + 1);  // the second branch (3 mm out), z = 42 (2 mm out)
  EXPECT_EQ(fit.dropped, 7 + 2);  // the third branch, z = 46 and 50 (6 and 10 mm out)
  EXPECT_DOUBLE_EQ(fit.max_snap_mm, 3.0);
  ASSERT_EQ(fit.graph.branches.size(), 3u);
  // The snapped branch lies on the top face, x and y unchanged.
  for (const Vector3d& p : fit.graph.branches[1].points) {
    EXPECT_NEAR(p.z(), 40.0, 1e-9);
    EXPECT_NEAR(p.y(), 10.0, 1e-9);
  }
  // Every kept point is in the mesh.
  const core::TetLocator locator(box.nodes(), box.tets());
  for (const auto& b : fit.graph.branches)
    for (const Vector3d& p : b.points) EXPECT_NEAR(locator.locate(p, 1.0)->distance, 0.0, 1e-9);
  // The inside branch keeps both its nodes; the cut one only its start.
  EXPECT_EQ(fit.graph.branches[0].points.front(), Vector3d(5, 20, 20));
  expect_error([&] { (void)fit_skeleton_to_mesh(g, box, -1.0); }, {"snap distance"});
}

}  // namespace
}  // namespace brainshift::imaging
