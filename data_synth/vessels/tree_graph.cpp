#include "data_synth/vessels/tree_graph.hpp"

#include "core/error.hpp"

#include <algorithm>
#include <deque>
#include <map>

namespace brainshift::data_synth {

imaging::VesselGraph to_vessel_graph(const VesselTree& tree) {
  tree.verify();
  const std::vector<int> deg = tree.degrees();
  std::vector<std::vector<index_t>> adjacent(tree.points.size());
  for (const auto& e : tree.edges) {
    adjacent[std::size_t(e[0])].push_back(e[1]);
    adjacent[std::size_t(e[1])].push_back(e[0]);
  }
  imaging::VesselGraph graph;
  std::vector<index_t> node_of(tree.points.size(), -1);
  for (std::size_t i = 0; i < tree.points.size(); ++i)
    if (deg[i] != 2 && deg[i] > 0) {
      node_of[i] = index_t(graph.nodes.size());
      graph.nodes.push_back({tree.points[i], tree.radius[i]});
    }
  // Walk each chain from a node along each of its edges; edges are used once.
  std::map<std::pair<index_t, index_t>, bool> used;
  auto key = [](index_t a, index_t b) { return std::make_pair(std::min(a, b), std::max(a, b)); };
  for (std::size_t s = 0; s < tree.points.size(); ++s) {
    if (node_of[s] < 0) continue;
    for (const index_t first : adjacent[s]) {
      if (used[key(index_t(s), first)]) continue;
      imaging::VesselGraph::Branch b;
      b.from = node_of[s];
      index_t prev = index_t(s), cur = first;
      b.points.push_back(tree.points[s]);
      b.radius.push_back(tree.radius[s]);
      used[key(prev, cur)] = true;
      while (true) {
        b.points.push_back(tree.points[std::size_t(cur)]);
        b.radius.push_back(tree.radius[std::size_t(cur)]);
        if (node_of[std::size_t(cur)] >= 0) break;
        const auto& adj = adjacent[std::size_t(cur)];
        const index_t next = adj[0] == prev ? adj[1] : adj[0];
        used[key(cur, next)] = true;
        prev = cur;
        cur = next;
      }
      b.to = node_of[std::size_t(cur)];
      graph.branches.push_back(std::move(b));
    }
  }
  return graph;
}

VesselTree from_vessel_graph(const imaging::VesselGraph& graph) {
  VesselTree tree;
  for (const auto& n : graph.nodes) {
    tree.points.push_back(n.position);
    tree.radius.push_back(n.radius);
  }
  for (const auto& b : graph.branches) {
    BS_VERIFY(b.points.size() >= 2 && b.radius.size() == b.points.size(),
              "vessel graph branch with " << b.points.size() << " points and " << b.radius.size()
                                          << " radii");
    index_t prev = b.from;
    for (std::size_t k = 1; k + 1 < b.points.size(); ++k) {
      tree.points.push_back(b.points[k]);
      tree.radius.push_back(b.radius[k]);
      const index_t cur = tree.size() - 1;
      tree.edges.push_back({prev, cur});
      prev = cur;
    }
    tree.edges.push_back({prev, b.to});
  }
  // Generations: BFS from the thickest degree-1 point of each component.
  tree.generation.assign(tree.points.size(), 0);
  std::vector<std::vector<index_t>> adjacent(tree.points.size());
  for (const auto& e : tree.edges) {
    adjacent[std::size_t(e[0])].push_back(e[1]);
    adjacent[std::size_t(e[1])].push_back(e[0]);
  }
  std::vector<index_t> order(tree.points.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = index_t(i);
  std::stable_sort(order.begin(), order.end(), [&](index_t a, index_t b) {
    const bool ea = adjacent[std::size_t(a)].size() == 1, eb = adjacent[std::size_t(b)].size() == 1;
    if (ea != eb) return ea;
    return tree.radius[std::size_t(a)] > tree.radius[std::size_t(b)];
  });
  for (const index_t root : order) {
    if (tree.generation[std::size_t(root)] != 0) continue;
    std::deque<index_t> queue{root};
    tree.generation[std::size_t(root)] = 1;
    while (!queue.empty()) {
      const index_t v = queue.front();
      queue.pop_front();
      const int step = adjacent[std::size_t(v)].size() >= 3 ? 1 : 0;
      for (const index_t w : adjacent[std::size_t(v)])
        if (tree.generation[std::size_t(w)] == 0) {
          tree.generation[std::size_t(w)] = tree.generation[std::size_t(v)] + step;
          queue.push_back(w);
        }
    }
  }
  return tree;
}

VesselTree place_user_tree(const VesselTree& user, const PhantomGeometry& geometry,
                           const TreePlacement& placement) {
  BS_VERIFY(user.size() > 0, "the user vessel tree is empty");
  BS_VERIFY(placement.target_extent > 0.0, "target_extent must be > 0 mm");
  VesselTree tree = user;
  Vector3d lo = Vector3d::Constant(1e300), hi = Vector3d::Constant(-1e300), mean = Vector3d::Zero();
  for (const Vector3d& p : tree.points) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
    mean += p;
  }
  mean /= double(tree.size());
  const double extent = (hi - lo).maxCoeff();
  const double scale = extent > 0.0 ? placement.target_extent / extent : 1.0;
  const Ellipsoid brain = geometry.brain_ellipsoid();
  const Vector3d cc = geometry.craniotomy_centre_on_brain();
  const Vector3d target = cc - placement.depth * brain.normal(cc);
  const Vector3d tc = geometry.tumour_centre();
  for (std::size_t i = 0; i < tree.points.size(); ++i) {
    Vector3d p = target + scale * (tree.points[i] - mean);
    if (!geometry.inside_brain(p) || p.z() < geometry.base_level() + 3.0) {
      p.z() = std::max(p.z(), geometry.base_level() + 3.0);
      const Vector3d c = brain.closest_point(p);
      p = c - 2.0 * brain.normal(c);
    }
    if ((p - tc).norm() < geometry.tumour_radius + 1.0)
      p = tc + (geometry.tumour_radius + 1.0) * (p - tc).normalized();
    for (int k = 0; k < 100 && geometry.label_at(p) == imaging::VENTRICLES; ++k)
      p += 1.0 * brain.normal(brain.closest_point(p));
    tree.points[i] = p;
    const double r = tree.radius[i] > 0.0 ? tree.radius[i] * scale : placement.default_radius;
    tree.radius[i] = std::clamp(r, placement.min_radius, placement.max_radius);
  }
  tree.verify();
  return tree;
}

}  // namespace brainshift::data_synth
