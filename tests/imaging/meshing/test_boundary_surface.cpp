#include "expect_error.hpp"
#include "surface_checks.hpp"
#include "tolerance.hpp"

#include "core/mapping/closest_point.hpp"
#include "data_synth/geometry/structured_mesh.hpp"
#include "imaging/meshing/boundary_surface.hpp"
#include "imaging/meshing/decimate_surface.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <map>
#include <numbers>
#include <set>

namespace brainshift::imaging {
namespace {

using tests::expect_error;
using tests::near;

TEST(OuterMeshSurface, OfABoxIsItsSixFacesOrientedOutward) {
  const core::TetMesh box =
      data_synth::make_box_mesh(Vector3d(10, 20, 30), Eigen::Vector3i(2, 3, 4));
  const MeshSurface s = outer_boundary_surface(box);
  EXPECT_EQ(s.surface.triangles.rows(), 2 * 2 * (2 * 3 + 3 * 4 + 2 * 4));  // 2 per boundary quad
  EXPECT_EQ(s.surface.vertices.rows(), 3 * 4 * 5 - 1 * 2 * 3);             // all but interior nodes
  EXPECT_TRUE(is_closed_and_consistent(s.surface));
  // Divergence theorem with outward normals gives the enclosed volume (exact up to rounding).
  EXPECT_TRUE(near(enclosed_volume(s.surface), 6000.0, 0.0, 1e-12));
  for (std::size_t v = 0; v < s.node.size(); ++v) {
    ASSERT_EQ(s.surface.vertices.row(index_t(v)), box.nodes().row(s.node[v]));
  }
}

TEST(FixedRegionNodes, AreTheSurfaceNodesWithinTheHeightOfTheLowestPoint) {
  // Node planes at z = 0, 7.5, 15, …; x = 0, 5, 10.
  const core::TetMesh box =
      data_synth::make_box_mesh(Vector3d(10, 20, 30), Eigen::Vector3i(2, 3, 4));
  const MeshSurface s = outer_boundary_surface(box);
  EXPECT_EQ(fixed_region_nodes(s, Vector3d(0, 0, -1), /*height=*/5.0).size(), 3u * 4u);
  // Up to z = 7.5: the bottom plane and the 10 surface nodes of the next plane.
  const auto two_planes = fixed_region_nodes(s, Vector3d(0, 0, -2), /*height=*/8.0);
  EXPECT_EQ(two_planes.size(), 3u * 4u + 10u);
  for (index_t n : two_planes) EXPECT_LE(box.nodes()(n, 2), 7.5 + 1e-12);
  // "Down" along +x: the x = 10 face.
  const auto side = fixed_region_nodes(s, Vector3d(1, 0, 0), /*height=*/1.0);
  EXPECT_EQ(side.size(), 4u * 5u);
  for (index_t n : side) EXPECT_EQ(box.nodes()(n, 0), 10.0);
  expect_error([&] { (void)fixed_region_nodes(s, Vector3d::Zero(), 1.0); }, {"down direction"});
}

TEST(DuraSurface, LeavesOutTheCraniotomyDisc) {
  const double r = 40.0, rho = 15.0;
  const core::TetMesh ball = data_synth::make_ellipsoid_mesh(Vector3d::Constant(r), /*cells=*/16);
  const MeshSurface outer = outer_boundary_surface(ball);
  const Vector3d centre(0.0, 0.0, r);
  const MeshSurface dura = dura_surface(outer, centre, rho);
  const auto& V = dura.surface.vertices;
  const auto& F = dura.surface.triangles;
  for (index_t f = 0; f < F.rows(); ++f) {
    const Vector3d c = (V.row(F(f, 0)) + V.row(F(f, 1)) + V.row(F(f, 2))).transpose() / 3.0;
    ASSERT_GT((c - centre).norm(), rho) << "triangle " << f;
  }
  for (std::size_t v = 0; v < dura.node.size(); ++v) {
    ASSERT_EQ(V.row(index_t(v)), ball.nodes().row(dura.node[v]));
  }
  // The removed cap has area π ρ² on a sphere (a ball of radius ρ around a point of the sphere cuts
  // a cap of height ρ²/2r); tolerance 25 %: the cut follows triangles ≈ 8 mm wide along a
  // 94 mm rim.
  const double removed = surface_area(outer.surface) - surface_area(dura.surface);
  EXPECT_TRUE(near(removed, std::numbers::pi * rho * rho, 0.0, 0.25));
  EXPECT_EQ(dura_surface(outer, centre, 0.0).surface.triangles.rows(),
            outer.surface.triangles.rows());
}

TEST(DecimateSurface, ReachesTheTargetAndStaysClosedAndClose) {
  const double r = 40.0;
  const core::TetMesh ball = data_synth::make_ellipsoid_mesh(Vector3d::Constant(r), /*cells=*/16);
  const core::SurfaceMesh full = outer_boundary_surface(ball).surface;
  ASSERT_GT(full.vertices.rows(), 1000);
  const core::SurfaceMesh coarse = decimate_surface(full, /*target_vertices=*/300);
  EXPECT_NEAR(double(coarse.vertices.rows()), 300.0, 30.0);  // ±10 %
  EXPECT_TRUE(is_closed_and_consistent(coarse));
  EXPECT_GT(enclosed_volume(coarse), 0.0);  // still outward
  // Vertex-sampled two-sided Hausdorff distance ≤ 2 mm (≈ the sagitta of 15 mm edges on r = 40).
  EXPECT_LE(vertex_hausdorff(coarse, full), 2.0);
}

TEST(DecimateSurface, FindsTheNonManifoldEdgesWhereThinPartsTouch) {
  // Two 10 mm cubes sharing only the edge x = y = 10: the boundary is closed but four faces meet
  // at that edge (what one-element-wide thin structures produce). Nodes merged by position.
  const core::TetMesh a = data_synth::make_box_mesh(Vector3d(10, 10, 10), Eigen::Vector3i(2, 2, 2));
  const core::TetMesh b = data_synth::make_box_mesh(Vector3d(10, 10, 10), Eigen::Vector3i(2, 2, 2),
                                                    Vector3d(10, 10, 0));
  std::map<std::array<long, 3>, index_t> id;
  std::vector<Vector3d> nodes;
  MatrixX4i tets(a.num_tets() + b.num_tets(), 4);
  index_t t = 0;
  for (const core::TetMesh* m : {&a, &b})
    for (index_t e = 0; e < m->num_tets(); ++e, ++t)
      for (int k = 0; k < 4; ++k) {
        const Vector3d p = m->nodes().row(m->tets()(e, k)).transpose();
        const std::array<long, 3> key{std::lround(p.x() * 1000), std::lround(p.y() * 1000),
                                      std::lround(p.z() * 1000)};
        auto [it, inserted] = id.try_emplace(key, static_cast<index_t>(nodes.size()));
        if (inserted) nodes.push_back(p);
        tets(t, k) = it->second;
      }
  MatrixX3d X(static_cast<index_t>(nodes.size()), 3);
  for (std::size_t i = 0; i < nodes.size(); ++i)
    X.row(static_cast<index_t>(i)) = nodes[i].transpose();
  const core::TetMesh both(X, tets);
  const core::SurfaceMesh full = outer_boundary_surface(both).surface;
  // The shared edge (2 segments of the cubes' 5 mm grid) is where four faces meet; nothing
  // else is non-manifold. decimate_surface() cannot take it (a halfedge mesh cannot hold it).
  EXPECT_EQ(count_non_manifold_edges(full), 2);
  EXPECT_EQ(count_non_manifold_edges(outer_boundary_surface(a).surface), 0);
  expect_error([&] { (void)decimate_surface(full, 30); }, {"non-manifold"});
}

TEST(DecimateSurface, RejectsOpenSurfaces) {
  const core::TetMesh box =
      data_synth::make_box_mesh(Vector3d(10, 20, 30), Eigen::Vector3i(2, 3, 4));
  core::SurfaceMesh open = outer_boundary_surface(box).surface;
  open.triangles.conservativeResize(open.triangles.rows() - 1, 3);
  expect_error([&] { (void)decimate_surface(open, 20); }, {"open edges"});
  expect_error([&] { (void)decimate_surface(open, 3); }, {"≥ 4"});
}

}  // namespace
}  // namespace brainshift::imaging
