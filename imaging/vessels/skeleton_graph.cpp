#include "imaging/vessels/skeleton_graph.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <unordered_map>

namespace brainshift::imaging {
namespace {

/// Reverses a branch in place (from ↔ to).
void reverse(VesselGraph::Branch& b) {
  std::reverse(b.points.begin(), b.points.end());
  std::reverse(b.radius.begin(), b.radius.end());
  std::swap(b.from, b.to);
}

/// Drops the branches flagged in `dead_branch`, then the nodes no branch touches, renumbering.
void compact(VesselGraph& graph, const std::vector<bool>& dead_branch) {
  std::vector<VesselGraph::Branch> kept;
  for (std::size_t b = 0; b < graph.branches.size(); ++b)
    if (!dead_branch[b]) kept.push_back(std::move(graph.branches[b]));
  graph.branches = std::move(kept);
  std::vector<index_t> new_index(graph.nodes.size(), -1);
  for (const auto& b : graph.branches)
    new_index[std::size_t(b.from)] = new_index[std::size_t(b.to)] = 0;
  std::vector<VesselGraph::Node> nodes;
  for (std::size_t n = 0; n < graph.nodes.size(); ++n)
    if (new_index[n] == 0) {
      new_index[n] = index_t(nodes.size());
      nodes.push_back(graph.nodes[n]);
    }
  graph.nodes = std::move(nodes);
  for (auto& b : graph.branches) {
    b.from = new_index[std::size_t(b.from)];
    b.to = new_index[std::size_t(b.to)];
  }
}

/// Joins the two branches at every node of degree 2 (not on a single-branch loop).
void merge_degree_two_nodes(VesselGraph& graph) {
  std::vector<bool> dead(graph.branches.size(), false);
  for (bool merged = true; merged;) {
    merged = false;
    std::vector<std::vector<std::size_t>> ends(graph.nodes.size());
    for (std::size_t b = 0; b < graph.branches.size(); ++b) {
      if (dead[b]) continue;
      ends[std::size_t(graph.branches[b].from)].push_back(b);
      ends[std::size_t(graph.branches[b].to)].push_back(b);
    }
    for (std::size_t n = 0; n < ends.size() && !merged; ++n) {
      if (ends[n].size() != 2 || ends[n][0] == ends[n][1]) continue;
      VesselGraph::Branch& first = graph.branches[ends[n][0]];
      VesselGraph::Branch& second = graph.branches[ends[n][1]];
      if (first.to != index_t(n)) reverse(first);
      if (second.from != index_t(n)) reverse(second);
      first.points.insert(first.points.end(), second.points.begin() + 1, second.points.end());
      first.radius.insert(first.radius.end(), second.radius.begin() + 1, second.radius.end());
      first.to = second.to;
      dead[ends[n][1]] = true;
      merged = true;
    }
  }
  compact(graph, dead);
}

}  // namespace

std::vector<int> VesselGraph::degrees() const {
  std::vector<int> degree(nodes.size(), 0);
  for (const auto& b : branches) {
    ++degree[std::size_t(b.from)];
    ++degree[std::size_t(b.to)];
  }
  return degree;
}

double polyline_length(const std::vector<Vector3d>& points) {
  double length = 0.0;
  for (std::size_t i = 1; i < points.size(); ++i) length += (points[i] - points[i - 1]).norm();
  return length;
}

double VesselGraph::total_length() const {
  double length = 0.0;
  for (const auto& b : branches) length += polyline_length(b.points);
  return length;
}

int VesselGraph::junction_count() const {
  const auto d = degrees();
  return int(std::count_if(d.begin(), d.end(), [](int x) { return x >= 3; }));
}

int VesselGraph::endpoint_count() const {
  const auto d = degrees();
  return int(std::count(d.begin(), d.end(), 1));
}

VesselGraph graph_from_skeleton(const Volume<std::uint8_t>& skeleton, const VolumeF& radius) {
  const ImageGeometry& g = skeleton.geometry;
  BS_VERIFY(radius.geometry.size == g.size && radius.components == 1 && skeleton.components == 1,
            "graph_from_skeleton: skeleton and radius volumes must share one-component grids");
  std::vector<std::int64_t> voxels;
  std::unordered_map<std::int64_t, int> id;
  for (std::int64_t v = 0; v < std::int64_t(skeleton.data.size()); ++v)
    if (skeleton.data[std::size_t(v)] != 0) {
      id.emplace(v, int(voxels.size()));
      voxels.push_back(v);
    }
  const std::size_t count = voxels.size();
  const auto ijk = [&](std::int64_t v) {
    return Eigen::Vector3i(int(v % g.size[0]), int((v / g.size[0]) % g.size[1]),
                           int(v / (std::int64_t(g.size[0]) * g.size[1])));
  };
  std::vector<std::vector<int>> adjacent(count);
  for (std::size_t s = 0; s < count; ++s) {
    const Eigen::Vector3i p = ijk(voxels[s]);
    for (int dz = -1; dz <= 1; ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          if ((dx | dy | dz) == 0 || !g.contains_index(p[0] + dx, p[1] + dy, p[2] + dz)) continue;
          const auto it = id.find(g.linear_index(p[0] + dx, p[1] + dy, p[2] + dz));
          if (it != id.end()) adjacent[s].push_back(it->second);
        }
  }
  const auto world = [&](int s) {
    return g.index_to_world(ijk(voxels[std::size_t(s)]).cast<double>());
  };
  const auto r = [&](int s) { return double(radius.data[std::size_t(voxels[std::size_t(s)])]); };

  // Node clusters: 26-connected groups of voxels with other than two neighbours.
  VesselGraph graph;
  std::vector<int> cluster(count, -1);
  const auto make_cluster = [&](int seed) {
    const int c = int(graph.nodes.size());
    std::vector<int> stack{seed}, members;
    cluster[std::size_t(seed)] = c;
    while (!stack.empty()) {
      const int s = stack.back();
      stack.pop_back();
      members.push_back(s);
      for (const int t : adjacent[std::size_t(s)])
        if (cluster[std::size_t(t)] < 0 && adjacent[std::size_t(t)].size() != 2) {
          cluster[std::size_t(t)] = c;
          stack.push_back(t);
        }
    }
    VesselGraph::Node node;
    for (const int s : members) {
      node.position += world(s) / double(members.size());
      node.radius = std::max(node.radius, r(s));
    }
    graph.nodes.push_back(node);
    return members;
  };
  std::vector<std::vector<int>> members;
  for (std::size_t s = 0; s < count; ++s)
    if (cluster[s] < 0 && adjacent[s].size() != 2) members.push_back(make_cluster(int(s)));

  std::vector<bool> visited(count, false);
  const auto trace = [&](int c, int from_voxel, int start) {
    VesselGraph::Branch b;
    b.from = c;
    b.points.push_back(graph.nodes[std::size_t(c)].position);
    b.radius.push_back(graph.nodes[std::size_t(c)].radius);
    int prev = from_voxel, cur = start;
    while (cluster[std::size_t(cur)] < 0) {
      visited[std::size_t(cur)] = true;
      b.points.push_back(world(cur));
      b.radius.push_back(r(cur));
      const auto& nb = adjacent[std::size_t(cur)];
      const int next = nb[0] == prev ? nb[1] : nb[0];
      prev = cur;
      cur = next;
    }
    b.to = cluster[std::size_t(cur)];
    b.points.push_back(graph.nodes[std::size_t(b.to)].position);
    b.radius.push_back(graph.nodes[std::size_t(b.to)].radius);
    // A two-neighbour voxel touching one cluster twice is part of that junction, not a branch.
    if (b.to == b.from && b.points.size() <= 4) return;
    graph.branches.push_back(std::move(b));
  };
  for (std::size_t c = 0; c < members.size(); ++c)
    for (const int u : members[c])
      for (const int w : adjacent[std::size_t(u)])
        if (cluster[std::size_t(w)] < 0 && !visited[std::size_t(w)]) trace(int(c), u, w);
  // Closed loops: one node on each, then trace around.
  for (std::size_t s = 0; s < count; ++s) {
    if (visited[s] || cluster[s] >= 0) continue;
    const int c = int(graph.nodes.size());
    cluster[s] = c;
    graph.nodes.push_back({world(int(s)), r(int(s))});
    trace(c, int(s), adjacent[s][0]);
  }
  merge_degree_two_nodes(graph);
  return graph;
}

int prune_spurs(VesselGraph& graph, const SpurPruning& rule) {
  int removed = 0;
  while (true) {
    const std::vector<int> degree = graph.degrees();
    std::map<index_t, std::pair<double, std::size_t>> shortest;  // junction → (length, branch)
    for (std::size_t b = 0; b < graph.branches.size(); ++b) {
      const auto& br = graph.branches[b];
      index_t junction = -1;
      if (degree[std::size_t(br.from)] == 1 && degree[std::size_t(br.to)] >= 3) junction = br.to;
      if (degree[std::size_t(br.to)] == 1 && degree[std::size_t(br.from)] >= 3) junction = br.from;
      if (junction < 0) continue;
      const double length = polyline_length(br.points);
      const double limit = std::max(rule.min_length_mm,
                                    rule.radius_factor * graph.nodes[std::size_t(junction)].radius);
      if (length >= limit) continue;
      const auto it = shortest.find(junction);
      if (it == shortest.end() || length < it->second.first) shortest[junction] = {length, b};
    }
    if (shortest.empty()) return removed;
    std::vector<bool> dead(graph.branches.size(), false);
    for (const auto& [junction, spur] : shortest) dead[spur.second] = true;
    removed += int(shortest.size());
    compact(graph, dead);
    merge_degree_two_nodes(graph);
  }
}

void smooth_branches(VesselGraph& graph, int passes) {
  for (auto& b : graph.branches) {
    const std::size_t n = b.points.size();
    if (n < 3) continue;
    for (int pass = 0; pass < passes; ++pass) {
      const std::vector<Vector3d> p = b.points;
      const std::vector<double> q = b.radius;
      for (std::size_t i = 1; i + 1 < n; ++i) {
        b.points[i] = 0.25 * p[i - 1] + 0.5 * p[i] + 0.25 * p[i + 1];
        b.radius[i] = 0.25 * q[i - 1] + 0.5 * q[i] + 0.25 * q[i + 1];
      }
    }
  }
}

void resample_branches(VesselGraph& graph, double step_mm) {
  BS_VERIFY(std::isfinite(step_mm) && step_mm > 0.0,
            "resampling step must be positive and finite, got " << step_mm << " mm");
  for (auto& b : graph.branches) {
    const double length = polyline_length(b.points);
    const int segments = std::max(1, int(std::ceil(length / step_mm - 1e-9)));
    std::vector<Vector3d> points{b.points.front()};
    std::vector<double> radii{b.radius.front()};
    std::size_t i = 0;
    double walked = 0.0;  // arc length at b.points[i]
    for (int m = 1; m < segments; ++m) {
      const double target = length * m / segments;
      while (i + 1 < b.points.size() && walked + (b.points[i + 1] - b.points[i]).norm() < target) {
        walked += (b.points[i + 1] - b.points[i]).norm();
        ++i;
      }
      const double seg = (b.points[i + 1] - b.points[i]).norm();
      const double t = seg > 0.0 ? (target - walked) / seg : 0.0;
      points.push_back(b.points[i] + t * (b.points[i + 1] - b.points[i]));
      radii.push_back(b.radius[i] + t * (b.radius[i + 1] - b.radius[i]));
    }
    points.push_back(b.points.back());
    radii.push_back(b.radius.back());
    b.points = std::move(points);
    b.radius = std::move(radii);
  }
}

core::Skeleton to_skeleton(const VesselGraph& graph) {
  std::size_t total = graph.nodes.size();
  for (const auto& b : graph.branches) total += b.points.size() - 2;
  core::Skeleton s;
  s.points.resize(Eigen::Index(total), 3);
  s.radius.resize(Eigen::Index(total));
  for (std::size_t n = 0; n < graph.nodes.size(); ++n) {
    s.points.row(Eigen::Index(n)) = graph.nodes[n].position.transpose();
    s.radius(Eigen::Index(n)) = graph.nodes[n].radius;
  }
  index_t next = index_t(graph.nodes.size());
  for (const auto& b : graph.branches) {
    index_t previous = b.from;
    for (std::size_t i = 1; i + 1 < b.points.size(); ++i) {
      s.points.row(next) = b.points[i].transpose();
      s.radius(next) = b.radius[i];
      s.segments.push_back({previous, next});
      previous = next++;
    }
    s.segments.push_back({previous, b.to});
  }
  return s;
}

}  // namespace brainshift::imaging
