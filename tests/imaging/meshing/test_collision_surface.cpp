#include "expect_error.hpp"
#include "surface_checks.hpp"
#include "tolerance.hpp"

#include "core/mapping/tet_locator.hpp"
#include "data_synth/geometry/structured_mesh.hpp"
#include "imaging/meshing/collision_surface.hpp"
#include "imaging/meshing/decimate_surface.hpp"
#include "imaging/meshing/wrap_surface.hpp"

#include <gtest/gtest.h>

#include <array>
#include <map>
#include <vector>

namespace brainshift::imaging {
namespace {

using tests::expect_error;
using tests::near;

/// Two `edge`-mm cubes (2 cells a side) touching along an edge (`shift` = (edge, edge, 0)) or at
/// a corner (`shift` = (edge, edge, edge)), nodes merged by position: one mesh whose boundary is
/// closed but not a manifold there, as where thin parts of a real brain touch.
core::TetMesh touching_cubes(double edge, const Vector3d& shift) {
  const core::TetMesh a =
      data_synth::make_box_mesh(Vector3d::Constant(edge), Eigen::Vector3i(2, 2, 2));
  const core::TetMesh b =
      data_synth::make_box_mesh(Vector3d::Constant(edge), Eigen::Vector3i(2, 2, 2), shift);
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
  return core::TetMesh(X, tets);
}

/// Largest distance of a surface vertex outside the mesh, mm.
double max_outside(const core::SurfaceMesh& s, const core::TetMesh& mesh) {
  const core::TetLocator locator(mesh.nodes(), mesh.tets());
  double worst = 0.0;
  for (index_t v = 0; v < s.vertices.rows(); ++v)
    worst = std::max(worst, locator.locate(s.vertices.row(v).transpose(), 1e9)->distance);
  return worst;
}

TEST(CollisionSurface, WrapsAndDecimatesABoundaryThatTouchesItselfAlongAnEdge) {
  const double edge = 40.0;
  const core::TetMesh mesh = touching_cubes(edge, Vector3d(edge, edge, 0.0));
  const MeshSurface outer = outer_boundary_surface(mesh);
  ASSERT_GT(count_non_manifold_edges(outer.surface), 0);
  CollisionSurfaceOptions o;
  o.target_vertices = 60;
  const CollisionSurface c = make_collision_surface(mesh, outer, o);
  EXPECT_TRUE(c.wrapped);
  EXPECT_EQ(c.non_manifold_edges, 2);  // the shared edge, two 20 mm cells long
  EXPECT_TRUE(is_closed_and_consistent(c.surface));
  EXPECT_EQ(count_non_manifold_edges(c.surface), 0);
  EXPECT_EQ(count_non_manifold_vertices(c.surface), 0);
  // Edge collapses stop at the edge count of the target: ± a few vertices (10 %).
  EXPECT_NEAR(double(c.surface.vertices.rows()), 60.0, 6.0);
  // Volume: the wrap lies 0.3 mm out (+ 0.3 × 19200 mm² = 5760 mm³, 4.5 %) and bridges the
  // notch at the shared edge (a wedge of ≈ alpha² × 40 mm, 0.5 %); decimation keeps the volume. 8
  // %.
  EXPECT_TRUE(near(enclosed_volume(c.surface), 2.0 * edge * edge * edge, 0.0, 0.08))
      << enclosed_volume(c.surface);
  // Every vertex maps into the mesh within the registration's 2 mm (moved ones are on it).
  EXPECT_LE(max_outside(c.surface, mesh), o.max_outside_mm + 1e-9);
}

TEST(CollisionSurface, WrapsABoundaryThatTouchesItselfAtOneVertex) {
  const double edge = 40.0;
  const core::TetMesh mesh = touching_cubes(edge, Vector3d::Constant(edge));
  const MeshSurface outer = outer_boundary_surface(mesh);
  EXPECT_EQ(count_non_manifold_edges(outer.surface), 0);  // the edge check alone misses it
  EXPECT_EQ(count_non_manifold_vertices(outer.surface), 1);
  CollisionSurfaceOptions o;
  o.target_vertices = 60;
  const CollisionSurface c = make_collision_surface(mesh, outer, o);
  EXPECT_TRUE(c.wrapped);
  EXPECT_TRUE(is_closed_and_consistent(c.surface));
  EXPECT_EQ(count_non_manifold_vertices(c.surface), 0);
}

TEST(CollisionSurface, DecimatesAManifoldBoundaryWithoutWrapping) {
  const core::TetMesh ball = data_synth::make_ellipsoid_mesh(Vector3d(70, 85, 60), /*cells=*/16);
  const MeshSurface outer = outer_boundary_surface(ball);
  const CollisionSurface c = make_collision_surface(ball, outer);
  EXPECT_FALSE(c.wrapped);
  EXPECT_EQ(c.non_manifold_vertices, 0);
  // The same surface as decimating the boundary directly (nothing moved: a convex shape's
  // decimated vertices lie within 1.5 mm of it).
  const core::SurfaceMesh direct = decimate_surface(outer.surface, 300);
  EXPECT_EQ(c.moved_vertices, 0);
  EXPECT_EQ(c.surface.vertices, direct.vertices);
  EXPECT_EQ(c.surface.triangles, direct.triangles);
}

TEST(CollisionSurface, RejectsBadOptions) {
  const core::TetMesh box =
      data_synth::make_box_mesh(Vector3d(10, 20, 30), Eigen::Vector3i(2, 3, 4));
  const MeshSurface outer = outer_boundary_surface(box);
  CollisionSurfaceOptions o;
  o.wrap_alpha_mm = 0.0;
  expect_error([&] { (void)make_collision_surface(box, outer, o); }, {"wrap_alpha_mm"});
  o = {};
  o.max_outside_mm = 2.5;  // the registration maps points only up to 2 mm outside
  expect_error([&] { (void)make_collision_surface(box, outer, o); }, {"max_outside_mm"});
  expect_error([&] { (void)wrap_surface(outer.surface, 1.0, -1.0); }, {"offset"});
}

}  // namespace
}  // namespace brainshift::imaging
