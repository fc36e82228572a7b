#include "core/mesh/boundary.hpp"

#include <algorithm>
#include <map>

namespace brainshift::core {

TriangleMatrix boundary_faces(const TetMesh& mesh) {
  // Faces opposite each vertex of a positively oriented tet (a,b,c,d), oriented outward.
  static constexpr int kFace[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
  std::map<std::array<index_t, 3>, std::pair<int, std::array<index_t, 3>>> count;
  const auto& T = mesh.tets();
  for (index_t t = 0; t < mesh.num_tets(); ++t)
    for (const auto& f : kFace) {
      std::array<index_t, 3> tri{T(t, f[0]), T(t, f[1]), T(t, f[2])};
      std::array<index_t, 3> key = tri;
      std::sort(key.begin(), key.end());
      auto [it, inserted] = count.try_emplace(key, 0, tri);
      ++it->second.first;
    }
  std::vector<std::array<index_t, 3>> out;
  for (const auto& [key, v] : count)
    if (v.first == 1) out.push_back(v.second);
  TriangleMatrix F(static_cast<Eigen::Index>(out.size()), 3);
  for (std::size_t i = 0; i < out.size(); ++i)
    F.row(static_cast<Eigen::Index>(i)) << out[i][0], out[i][1], out[i][2];
  return F;
}

BoundarySurface boundary_surface(const TetMesh& mesh) {
  BoundarySurface s;
  s.faces = boundary_faces(mesh);
  std::vector<index_t> vertex_of_node(static_cast<std::size_t>(mesh.num_nodes()), -1);
  for (Eigen::Index i = 0; i < s.faces.size(); ++i) {
    index_t& v = vertex_of_node[static_cast<std::size_t>(s.faces.data()[i])];
    if (v < 0) {
      v = static_cast<index_t>(s.node_of_vertex.size());
      s.node_of_vertex.push_back(s.faces.data()[i]);
    }
    s.faces.data()[i] = v;
  }
  s.vertices.resize(static_cast<Eigen::Index>(s.node_of_vertex.size()), 3);
  for (std::size_t v = 0; v < s.node_of_vertex.size(); ++v)
    s.vertices.row(static_cast<Eigen::Index>(v)) = mesh.nodes().row(s.node_of_vertex[v]);
  return s;
}

}  // namespace brainshift::core
