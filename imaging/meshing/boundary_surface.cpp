#include "imaging/meshing/boundary_surface.hpp"

#include "core/error.hpp"
#include "core/mesh/boundary.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>

namespace brainshift::imaging {

namespace {

using Face = std::array<index_t, 3>;

index_t find_root(std::vector<index_t>& parent, index_t v) {
  while (parent[std::size_t(v)] != v) {
    parent[std::size_t(v)] = parent[std::size_t(parent[std::size_t(v)])];
    v = parent[std::size_t(v)];
  }
  return v;
}

/// Surface from oriented triangles given by mesh-node indices (vertices renumbered by node order).
MeshSurface make_surface(const MatrixX3d& node_positions, const std::vector<Face>& faces) {
  MeshSurface out;
  std::vector<index_t> vertex_of(std::size_t(node_positions.rows()), -1);
  for (const Face& f : faces) {
    for (index_t n : f) vertex_of[std::size_t(n)] = 0;
  }
  for (std::size_t n = 0; n < vertex_of.size(); ++n) {
    if (vertex_of[n] < 0) continue;
    vertex_of[n] = index_t(out.node.size());
    out.node.push_back(index_t(n));
  }
  out.surface.vertices.resize(index_t(out.node.size()), 3);
  for (std::size_t v = 0; v < out.node.size(); ++v) {
    out.surface.vertices.row(index_t(v)) = node_positions.row(out.node[v]);
  }
  out.surface.triangles.resize(index_t(faces.size()), 3);
  for (std::size_t f = 0; f < faces.size(); ++f) {
    for (int c = 0; c < 3; ++c) {
      out.surface.triangles(index_t(f), c) = vertex_of[std::size_t(faces[f][std::size_t(c)])];
    }
  }
  return out;
}

}  // namespace

MeshSurface outer_boundary_surface(const core::TetMesh& mesh) {
  BS_VERIFY(mesh.num_tets() > 0, "the mesh has no tetrahedron: no boundary surface");
  const core::TriangleMatrix faces = core::boundary_faces(mesh);
  std::vector<Face> boundary(std::size_t(faces.rows()));
  for (index_t f = 0; f < faces.rows(); ++f)
    boundary[std::size_t(f)] = {faces(f, 0), faces(f, 1), faces(f, 2)};
  // Keep the component of the boundary node with the largest x (it must be on the outside).
  std::vector<index_t> parent(std::size_t(mesh.num_nodes()));
  std::iota(parent.begin(), parent.end(), 0);
  index_t extreme = boundary.front()[0];
  for (const Face& f : boundary) {
    for (int c = 0; c < 3; ++c) {
      if (mesh.nodes()(f[std::size_t(c)], 0) > mesh.nodes()(extreme, 0))
        extreme = f[std::size_t(c)];
    }
    parent[std::size_t(find_root(parent, f[1]))] = find_root(parent, f[0]);
    parent[std::size_t(find_root(parent, f[2]))] = find_root(parent, f[0]);
  }
  const index_t outer_root = find_root(parent, extreme);
  std::vector<Face> outer;
  for (const Face& f : boundary) {
    if (find_root(parent, f[0]) == outer_root) outer.push_back(f);
  }
  return make_surface(mesh.nodes(), outer);
}

std::vector<index_t> fixed_region_nodes(const MeshSurface& outer, const Vector3d& down,
                                        double height) {
  BS_VERIFY(down.allFinite() && down.norm() > 0.0,
            "fixed region: the down direction must be a non-zero vector, got " << down.transpose());
  BS_VERIFY(std::isfinite(height) && height >= 0.0,
            "fixed region: height must be ≥ 0 mm, got " << height);
  BS_VERIFY(outer.node.size() == std::size_t(outer.surface.vertices.rows()),
            "fixed region: surface has " << outer.surface.vertices.rows() << " vertices but "
                                         << outer.node.size() << " node indices");
  if (outer.node.empty()) return {};
  const Eigen::VectorXd depth = outer.surface.vertices * down.normalized();  // larger = lower
  const double lowest = depth.maxCoeff();
  std::vector<index_t> nodes;
  for (index_t v = 0; v < depth.size(); ++v) {
    if (depth[v] >= lowest - height) nodes.push_back(outer.node[std::size_t(v)]);
  }
  std::sort(nodes.begin(), nodes.end());
  return nodes;
}

MeshSurface dura_surface(const MeshSurface& outer, const Vector3d& centre, double radius) {
  BS_VERIFY(centre.allFinite(), "dura surface: craniotomy centre is not finite");
  BS_VERIFY(std::isfinite(radius) && radius >= 0.0,
            "dura surface: craniotomy radius must be ≥ 0 mm, got " << radius);
  const auto& V = outer.surface.vertices;
  const auto& F = outer.surface.triangles;
  BS_VERIFY(outer.node.size() == std::size_t(V.rows()),
            "dura surface: surface has " << V.rows() << " vertices but " << outer.node.size()
                                         << " node indices");
  // Work in node numbering so make_surface() renumbers the kept vertices.
  index_t max_node = -1;
  for (index_t n : outer.node) max_node = std::max(max_node, n);
  MatrixX3d node_positions = MatrixX3d::Zero(max_node + 1, 3);
  for (index_t v = 0; v < V.rows(); ++v) node_positions.row(outer.node[std::size_t(v)]) = V.row(v);
  std::vector<Face> kept;
  for (index_t f = 0; f < F.rows(); ++f) {
    const Vector3d centroid = (V.row(F(f, 0)) + V.row(F(f, 1)) + V.row(F(f, 2))).transpose() / 3.0;
    if ((centroid - centre).norm() <= radius) continue;
    kept.push_back({outer.node[std::size_t(F(f, 0))], outer.node[std::size_t(F(f, 1))],
                    outer.node[std::size_t(F(f, 2))]});
  }
  return make_surface(node_positions, kept);
}

}  // namespace brainshift::imaging
