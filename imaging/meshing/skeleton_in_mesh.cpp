#include "imaging/meshing/skeleton_in_mesh.hpp"

#include "core/error.hpp"
#include "core/mapping/tet_locator.hpp"

#include <algorithm>
#include <cmath>
#include <optional>
#include <unordered_map>

namespace brainshift::imaging {

SkeletonFit fit_skeleton_to_mesh(const VesselGraph& graph, const core::TetMesh& mesh,
                                 double snap_distance_mm) {
  BS_VERIFY(std::isfinite(snap_distance_mm) && snap_distance_mm >= 0.0,
            "vessel snap distance must be ≥ 0 mm, got " << snap_distance_mm);
  BS_VERIFY(mesh.num_tets() > 0, "the mesh has no tetrahedron: no vessel can be mapped into it");
  const core::TetLocator locator(mesh.nodes(), mesh.tets());
  SkeletonFit fit;
  double snap_sum = 0.0;
  // Where each point goes: its position in the mesh, or nothing (dropped).
  const auto place = [&](const Vector3d& p) -> std::optional<Vector3d> {
    const auto loc = locator.locate(p, snap_distance_mm);
    if (!loc) return std::nullopt;
    if (loc->distance <= 0.0) return p;
    Vector3d q = Vector3d::Zero();
    for (int k = 0; k < 4; ++k)
      q += loc->barycentric(k) * mesh.nodes().row(mesh.tets()(loc->tet, k)).transpose();
    return q;
  };
  std::unordered_map<index_t, index_t> node_of;  // input node → output node (kept branch ends)
  const auto end_node = [&](index_t old_node, const Vector3d& p, double r) {
    if (old_node >= 0) {
      const auto it = node_of.find(old_node);
      if (it != node_of.end()) return it->second;
    }
    fit.graph.nodes.push_back({p, r});
    const auto id = static_cast<index_t>(fit.graph.nodes.size() - 1);
    if (old_node >= 0) node_of.emplace(old_node, id);
    return id;
  };
  for (const auto& b : graph.branches) {
    const std::size_t n = b.points.size();
    std::vector<std::optional<Vector3d>> placed(n);
    for (std::size_t i = 0; i < n; ++i) placed[i] = place(b.points[i]);
    fit.points += static_cast<index_t>(n);
    std::size_t i = 0;
    while (i < n) {
      while (i < n && !placed[i]) {
        ++fit.dropped;
        ++i;
      }
      std::size_t j = i;
      while (j < n && placed[j]) ++j;
      if (j - i == 1) ++fit.dropped;  // a lone point is no centreline
      if (j - i >= 2) {
        VesselGraph::Branch nb;
        for (std::size_t k = i; k < j; ++k) {
          const double moved = (*placed[k] - b.points[k]).norm();
          if (moved > 0.0) {
            ++fit.snapped;
            snap_sum += moved;
            fit.max_snap_mm = std::max(fit.max_snap_mm, moved);
          } else {
            ++fit.inside;
          }
          nb.points.push_back(*placed[k]);
          nb.radius.push_back(b.radius[k]);
        }
        nb.from = end_node(i == 0 ? b.from : -1, nb.points.front(), nb.radius.front());
        nb.to = end_node(j == n ? b.to : -1, nb.points.back(), nb.radius.back());
        fit.graph.branches.push_back(std::move(nb));
      }
      i = j;
    }
  }
  fit.mean_snap_mm = fit.snapped > 0 ? snap_sum / double(fit.snapped) : 0.0;
  return fit;
}

}  // namespace brainshift::imaging
