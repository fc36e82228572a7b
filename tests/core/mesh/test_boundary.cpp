#include "core/mesh/boundary.hpp"
#include "data_synth/geometry/structured_mesh.hpp"

#include <gtest/gtest.h>

#include <map>

namespace brainshift::core {
namespace {

/// Volume enclosed by a closed, outward surface: Σ (a · (b × c)) / 6 (divergence theorem); the
/// sign tells the orientation, so this checks orientation and closure independently of the tets.
double enclosed_volume(const MatrixX3d& V, const TriangleMatrix& F) {
  double v = 0;
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    v += V.row(F(f, 0)).dot(V.row(F(f, 1)).cross(V.row(F(f, 2)))) / 6.0;
  return v;
}

TEST(Boundary, BoxSurfaceIsClosedOutwardAndEnclosesTheMeshVolume) {
  const TetMesh m = data_synth::make_box_mesh({20, 10, 30}, {4, 2, 6}, {-3, 5, 1});
  const TriangleMatrix F = boundary_faces(m);
  // Each boundary quad of the structured box is split into 2 triangles.
  EXPECT_EQ(F.rows(), 2 * 2 * (4 * 2 + 2 * 6 + 4 * 6));
  // Exact up to rounding: the same tetrahedra, summed two ways.
  EXPECT_NEAR(enclosed_volume(m.nodes(), F), 20.0 * 10.0 * 30.0, 1e-9);
  // Closed 2-manifold: every undirected edge is shared by exactly two faces, once each way.
  std::map<std::pair<index_t, index_t>, int> directed;
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k) ++directed[{F(f, k), F(f, (k + 1) % 3)}];
  for (const auto& [e, n] : directed) {
    EXPECT_EQ(n, 1);
    EXPECT_EQ(directed.count({e.second, e.first}), 1u);
  }
}

TEST(Boundary, SurfaceReindexesToUsedNodesOnly) {
  const TetMesh m = data_synth::make_ellipsoid_mesh({40, 35, 30}, 6);
  const BoundarySurface s = boundary_surface(m);
  double volume = 0;
  for (index_t t = 0; t < m.num_tets(); ++t) volume += m.signed_volume(t);
  EXPECT_NEAR(enclosed_volume(s.vertices, s.faces), volume, 1e-9 * volume);
  ASSERT_EQ(static_cast<Eigen::Index>(s.node_of_vertex.size()), s.vertices.rows());
  EXPECT_LT(s.vertices.rows(), m.num_nodes());  // interior nodes are not surface vertices
  for (std::size_t v = 0; v < s.node_of_vertex.size(); ++v)
    EXPECT_EQ(s.vertices.row(static_cast<Eigen::Index>(v)), m.nodes().row(s.node_of_vertex[v]));
}

}  // namespace
}  // namespace brainshift::core
