#include "imaging/vessels/support_edge.hpp"

#include "core/error.hpp"
#include "imaging/vessels/distance_transform.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

namespace brainshift::imaging {
namespace {

bool blank(float v) { return !std::isfinite(v) || v == 0.0F; }

/// The outside region: blank voxels 6-connected to a face of the grid through blank voxels.
std::vector<std::uint8_t> outside_region(const VolumeF& image, std::int64_t& count) {
  const ImageGeometry& g = image.geometry;
  std::vector<std::uint8_t> out(std::size_t(g.voxel_count()), 0);
  std::vector<std::int64_t> stack;
  auto push = [&](int i, int j, int k) {
    const std::int64_t v = g.linear_index(i, j, k);
    if (out[std::size_t(v)] || !blank(image.data[std::size_t(v)])) return;
    out[std::size_t(v)] = 1;
    stack.push_back(v);
  };
  for (int k = 0; k < g.size[2]; ++k)
    for (int j = 0; j < g.size[1]; ++j)
      for (int i = 0; i < g.size[0]; ++i)
        if (i == 0 || j == 0 || k == 0 || i == g.size[0] - 1 || j == g.size[1] - 1 ||
            k == g.size[2] - 1)
          push(i, j, k);
  const std::int64_t nx = g.size[0], nxy = nx * g.size[1];
  while (!stack.empty()) {
    const std::int64_t v = stack.back();
    stack.pop_back();
    const int k = int(v / nxy), j = int((v % nxy) / nx), i = int(v % nx);
    if (i > 0) push(i - 1, j, k);
    if (i + 1 < g.size[0]) push(i + 1, j, k);
    if (j > 0) push(i, j - 1, k);
    if (j + 1 < g.size[1]) push(i, j + 1, k);
    if (k > 0) push(i, j, k - 1);
    if (k + 1 < g.size[2]) push(i, j, k + 1);
  }
  count = std::count(out.begin(), out.end(), std::uint8_t(1));
  return out;
}

}  // namespace

SupportEdgeResult drop_points_at_support_edge(VesselGraph& graph, const VolumeF& image,
                                              std::int64_t foreground_voxels, double margin_mm,
                                              double min_support_ratio) {
  BS_VERIFY(image.components == 1,
            "support edge: needs a one-component volume, got " << image.components);
  BS_VERIFY(margin_mm >= 0.0 && std::isfinite(margin_mm),
            "support edge: margin must be a finite value >= 0 mm, got " << margin_mm);
  BS_VERIFY(min_support_ratio >= 1.0,
            "support edge: min_support_ratio must be >= 1, got " << min_support_ratio);
  SupportEdgeResult result;
  if (graph.branches.empty() || image.empty()) return result;
  // Without a sector nothing is dropped: the grid's faces are not treated as an edge.
  const ImageGeometry& g = image.geometry;

  std::int64_t outside_count = 0;
  std::vector<std::uint8_t> outside = outside_region(image, outside_count);
  const std::int64_t support = g.voxel_count() - outside_count;
  result.sector_found =
      outside_count > 0 && double(support) >= min_support_ratio * double(foreground_voxels);
  if (!result.sector_found) return result;
  result.outside_voxels = outside_count;

  // The distance transform on the points' bounding box grown by more than any distance the
  // rule compares (an inner face of the box counts as outside, but lies farther than that).
  double max_radius = 0.0;
  for (const auto& b : graph.branches)
    for (const double r : b.radius) max_radius = std::max(max_radius, r);
  for (const auto& n : graph.nodes) max_radius = std::max(max_radius, n.radius);
  const double h = g.spacing.minCoeff();
  const int grow = int(std::ceil((max_radius + margin_mm) / h)) + 2;
  Eigen::Vector3i lo = g.size, hi = Eigen::Vector3i::Constant(-1);
  auto nearest_index = [&](const Vector3d& p) {
    const Vector3d ijk = g.world_to_index(p);
    Eigen::Vector3i n;
    for (int d = 0; d < 3; ++d) n[d] = std::clamp(int(std::lround(ijk[d])), 0, g.size[d] - 1);
    return n;
  };
  for (const auto& b : graph.branches)
    for (const Vector3d& p : b.points) {
      const Eigen::Vector3i n = nearest_index(p);
      lo = lo.cwiseMin(n);
      hi = hi.cwiseMax(n);
    }
  // Not clamped to the grid: beyond its faces is support (the grid's faces are no edge).
  lo.array() -= grow;
  hi.array() += grow;
  ImageGeometry crop = g;
  crop.size = hi - lo + Eigen::Vector3i::Ones();
  Volume<std::uint8_t> mask(crop, 1, 1);
  for (int k = std::max(0, lo[2]); k <= std::min(g.size[2] - 1, hi[2]); ++k)
    for (int j = std::max(0, lo[1]); j <= std::min(g.size[1] - 1, hi[1]); ++j)
      for (int i = std::max(0, lo[0]); i <= std::min(g.size[0] - 1, hi[0]); ++i)
        mask.at(i - lo[0], j - lo[1], k - lo[2]) =
            outside[std::size_t(g.linear_index(i, j, k))] ? 0 : 1;
  const VolumeF distance = distance_to_background(mask);
  auto at_edge = [&](const Vector3d& p, double r) {
    const Eigen::Vector3i n = nearest_index(p) - lo;
    const double d = double(distance.at(n[0], n[1], n[2])) - 0.5 * h;  // to the edge itself
    return d < r + margin_mm;
  };

  // Cut the branches at the dropped points.
  std::vector<bool> node_dropped(graph.nodes.size());
  for (std::size_t n = 0; n < graph.nodes.size(); ++n) {
    node_dropped[n] = at_edge(graph.nodes[n].position, graph.nodes[n].radius);
    result.dropped += node_dropped[n] ? 1 : 0;
  }
  VesselGraph out;
  out.nodes = graph.nodes;
  for (const auto& b : graph.branches) {
    const std::size_t m = b.points.size();
    std::vector<bool> keep(m);
    for (std::size_t i = 0; i < m; ++i) {
      const bool end = i == 0 || i + 1 == m;
      keep[i] = end ? !node_dropped[std::size_t(i == 0 ? b.from : b.to)]
                    : !at_edge(b.points[i], b.radius[i]);
      if (!end && !keep[i]) ++result.dropped;
    }
    for (std::size_t i = 0; i < m;) {
      if (!keep[i]) {
        ++i;
        continue;
      }
      std::size_t j = i;
      while (j + 1 < m && keep[j + 1]) ++j;
      if (j > i) {
        VesselGraph::Branch run;
        run.points.assign(b.points.begin() + std::ptrdiff_t(i),
                          b.points.begin() + std::ptrdiff_t(j + 1));
        run.radius.assign(b.radius.begin() + std::ptrdiff_t(i),
                          b.radius.begin() + std::ptrdiff_t(j + 1));
        auto end_node = [&](std::size_t at, index_t original) {
          if ((at == 0 && original == b.from) || (at + 1 == m && original == b.to)) return original;
          out.nodes.push_back({b.points[at], b.radius[at]});
          return index_t(out.nodes.size() - 1);
        };
        run.from = end_node(i, i == 0 ? b.from : -1);
        run.to = end_node(j, j + 1 == m ? b.to : -1);
        out.branches.push_back(std::move(run));
      }
      i = j + 1;
    }
  }
  // Nodes no branch uses go (renumbered).
  std::vector<index_t> index(out.nodes.size(), -1);
  for (const auto& b : out.branches) index[std::size_t(b.from)] = index[std::size_t(b.to)] = 0;
  std::vector<VesselGraph::Node> nodes;
  for (std::size_t n = 0; n < out.nodes.size(); ++n)
    if (index[n] == 0) {
      index[n] = index_t(nodes.size());
      nodes.push_back(out.nodes[n]);
    }
  for (auto& b : out.branches) {
    b.from = index[std::size_t(b.from)];
    b.to = index[std::size_t(b.to)];
  }
  out.nodes = std::move(nodes);
  graph = std::move(out);
  return result;
}

}  // namespace brainshift::imaging
