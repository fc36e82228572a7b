#include "data_synth/vessels/vessel_tree.hpp"

#include "core/error.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <sstream>

namespace brainshift::data_synth {

std::vector<int> VesselTree::degrees() const {
  std::vector<int> d(points.size(), 0);
  for (const auto& e : edges) {
    ++d[std::size_t(e[0])];
    ++d[std::size_t(e[1])];
  }
  return d;
}

std::vector<index_t> VesselTree::bifurcations() const {
  const std::vector<int> d = degrees();
  std::vector<index_t> out;
  for (std::size_t i = 0; i < d.size(); ++i)
    if (d[i] >= 3) out.push_back(index_t(i));
  return out;
}

int VesselTree::max_generation() const {
  return generation.empty() ? 0 : *std::max_element(generation.begin(), generation.end());
}

void VesselTree::verify() const {
  BS_VERIFY(radius.size() == points.size() && generation.size() == points.size(),
            "vessel tree: " << points.size() << " points but " << radius.size() << " radii and "
                            << generation.size() << " generations");
  for (std::size_t i = 0; i < points.size(); ++i) {
    BS_VERIFY(points[i].allFinite(), "vessel tree: point " << i << " is not finite");
    BS_VERIFY(radius[i] > 0.0 && std::isfinite(radius[i]),
              "vessel tree: point " << i << " has radius " << radius[i] << " mm, expected > 0");
  }
  for (std::size_t e = 0; e < edges.size(); ++e)
    for (const index_t v : edges[e])
      BS_VERIFY(v >= 0 && v < size() && edges[e][0] != edges[e][1],
                "vessel tree: edge " << e << " (" << edges[e][0] << ", " << edges[e][1]
                                     << ") is invalid for " << size() << " points");
}

std::string VesselTreeOptions::validate() const {
  std::ostringstream s;
  if (cortical_trees < 0)
    s << "cortical_trees must be >= 0, got " << cortical_trees;
  else if (!(min_radius > 0.0 && min_radius <= root_radius_min &&
             root_radius_min <= root_radius_max && root_radius_max <= max_radius))
    s << "radii must satisfy 0 < min_radius <= root_radius_min <= root_radius_max <= max_radius, "
         "got "
      << min_radius << ", " << root_radius_min << ", " << root_radius_max << ", " << max_radius;
  else if (min_generations < 1 || max_generations < min_generations)
    s << "generations must satisfy 1 <= min <= max, got " << min_generations << ", "
      << max_generations;
  else if (!(min_depth >= 0.0 && max_depth >= min_depth))
    s << "depths must satisfy 0 <= min_depth <= max_depth, got " << min_depth << ", " << max_depth;
  else if (!(step > 0.0) || !(length_per_radius > 0.0) || !(root_spread >= 0.0))
    s << "step, length_per_radius must be > 0 and root_spread >= 0";
  else if (deep_branches < 0 || deep_generations < 0 || !(deep_radius >= min_radius) ||
           !(tumour_shell > 1.0))
    s << "deep branches: count and generations >= 0, deep_radius >= min_radius, tumour_shell > 1 "
         "mm";
  return s.str();
}

namespace {

/// The surface a branch follows: the brain ellipsoid offset inward by `offset` (cortical), or a
/// sphere `offset` mm outside the tumour (deep).
struct Guide {
  bool cortical = true;
  double offset = 2.0;  ///< mm
};

/// One branch to grow: from an existing point, in a direction, at a radius and generation.
struct BranchJob {
  index_t start = 0;
  Vector3d direction;
  double radius = 1.0;
  int generation = 1;
  int max_generation = 1;
  Guide guide;
};

class TreeGrower {
 public:
  TreeGrower(const BrainShape& g, const VesselTreeOptions& o) : m_g(g), m_o(o), m_rng(o.seed) {}

  VesselTree grow() {
    for (int t = 0; t < m_o.cortical_trees; ++t) grow_cortical_tree(t);
    const index_t cortical_points = m_tree.size();
    for (int b = 0; b < m_o.deep_branches; ++b) grow_deep_branch(cortical_points);
    return std::move(m_tree);
  }

 private:
  double uniform(double a, double b) { return std::uniform_real_distribution<double>(a, b)(m_rng); }
  double gaussian(double sigma) { return std::normal_distribution<double>(0.0, sigma)(m_rng); }
  static double deg(double d) { return d * std::numbers::pi / 180.0; }

  [[nodiscard]] bool valid(const Vector3d& p) const {
    return m_g.label_at(p) == imaging::BRAIN &&
           (p - m_g.tumour_centre).norm() >= m_g.tumour_radius + 1.0 &&
           p.z() >= m_g.base_level + 3.0;
  }

  /// Unit normal of the guide surface near p (outward).
  [[nodiscard]] Vector3d guide_normal(const Vector3d& p, const Guide& guide) const {
    if (guide.cortical) return m_g.surface_normal(m_g.closest_surface_point(p));
    return (p - m_g.tumour_centre).normalized();
  }
  [[nodiscard]] Vector3d project(const Vector3d& q, const Guide& guide) const {
    if (guide.cortical) {
      const Vector3d c = m_g.closest_surface_point(q);
      return c - guide.offset * m_g.surface_normal(c);
    }
    const Vector3d tc = m_g.tumour_centre;
    return tc + (m_g.tumour_radius + guide.offset) * (q - tc).normalized();
  }

  index_t add_point(const Vector3d& p, double r, int generation, index_t parent) {
    m_tree.points.push_back(p);
    m_tree.radius.push_back(std::clamp(r, m_o.min_radius, m_o.max_radius));
    m_tree.generation.push_back(generation);
    const index_t i = m_tree.size() - 1;
    if (parent >= 0) m_tree.edges.push_back({parent, i});
    return i;
  }

  Guide random_guide(bool cortical) {
    if (cortical) return {true, uniform(m_o.min_depth, m_o.max_depth)};
    return {false, uniform(0.75 * m_o.tumour_shell, 1.25 * m_o.tumour_shell)};
  }

  void grow_cortical_tree(int t) {
    const Vector3d cc = m_g.craniotomy_centre;
    const Vector3d n = m_g.surface_normal(cc);
    const Vector3d t1 = (Vector3d::UnitX() - Vector3d::UnitX().dot(n) * n).normalized();
    const Vector3d t2 = n.cross(t1);
    const double pi = std::numbers::pi;
    const int count = m_o.cortical_trees;
    for (int attempt = 0; attempt < 20; ++attempt) {
      const double phi = m_o.one_side ? -0.5 * pi + pi * (t + 0.5 + uniform(-0.3, 0.3)) / count
                                      : 2.0 * pi * (t + uniform(-0.2, 0.2)) / count;
      const double rho = uniform(0.4, 1.0) * m_o.root_spread;
      const Guide guide = random_guide(true);
      const Vector3d root = project(cc + rho * (std::cos(phi) * t1 + std::sin(phi) * t2), guide);
      if (!valid(root)) continue;
      const Vector3d nr = guide_normal(root, guide);
      Vector3d toward = cc - root;
      toward -= toward.dot(nr) * nr;
      if (toward.norm() < 1e-6) toward = nr.unitOrthogonal();
      const Vector3d dir = Eigen::AngleAxisd(deg(uniform(-25.0, 25.0)), nr) * toward.normalized();
      const double r = uniform(m_o.root_radius_min, m_o.root_radius_max);
      const int cap =
          std::uniform_int_distribution<int>(m_o.min_generations, m_o.max_generations)(m_rng);
      const index_t start = add_point(root, r, 1, -1);
      run({start, dir, r, 1, cap, guide});
      return;
    }
  }

  /// Grows a job and all its descendants (depth first, deterministic order).
  void run(BranchJob first) {
    std::vector<BranchJob> stack{std::move(first)};
    while (!stack.empty()) {
      const BranchJob job = stack.back();
      stack.pop_back();
      grow_branch(job, stack);
    }
  }

  void grow_branch(const BranchJob& job, std::vector<BranchJob>& stack) {
    const double length = m_o.length_per_radius * job.radius * uniform(0.7, 1.3) + 4.0;
    const int steps = std::max(2, int(std::lround(length / m_o.step)));
    Vector3d p = m_tree.points[std::size_t(job.start)];
    Vector3d dir = job.direction;
    index_t prev = job.start;
    for (int k = 0; k < steps; ++k) {
      const Vector3d n = guide_normal(p, job.guide);
      dir -= dir.dot(n) * n;
      if (dir.norm() < 1e-9) break;
      dir = Eigen::AngleAxisd(deg(gaussian(m_o.wander_deg)), n) * dir.normalized();
      const Vector3d q = project(p + m_o.step * dir, job.guide);
      if (!valid(q) || (q - p).norm() < 0.2 * m_o.step) break;
      dir = (q - p).normalized();
      prev = add_point(q, job.radius, job.generation, prev);
      p = q;
    }
    if (prev == job.start || job.generation >= job.max_generation) return;
    split(prev, dir, job, stack);
  }

  /// Bifurcation at the end of a branch: Murray's law r³ = r₁³ + r₂³ with a random split; the
  /// thinner child turns more. No split when a child would be thinner than min_radius.
  void split(index_t at, const Vector3d& dir, const BranchJob& job, std::vector<BranchJob>& stack) {
    const double r3 = std::pow(job.radius, 3.0);
    const double rmin3 = std::pow(m_o.min_radius, 3.0);
    if (r3 < 2.0 * rmin3) return;
    const double alpha = uniform(0.3, 0.7);
    double small3 = std::min(alpha, 1.0 - alpha) * r3;
    small3 = std::max(small3, rmin3);
    const double r_small = std::cbrt(small3), r_big = std::cbrt(r3 - small3);
    const Vector3d n = guide_normal(m_tree.points[std::size_t(at)], job.guide);
    const double side = uniform(0.0, 1.0) < 0.5 ? 1.0 : -1.0;
    const Vector3d d_big = Eigen::AngleAxisd(side * deg(uniform(15.0, 35.0)), n) * dir;
    const Vector3d d_small = Eigen::AngleAxisd(-side * deg(uniform(30.0, 60.0)), n) * dir;
    const int g = job.generation + 1;
    stack.push_back(
        {at, d_small, r_small, g, job.max_generation, random_guide(job.guide.cortical)});
    stack.push_back({at, d_big, r_big, g, job.max_generation, random_guide(job.guide.cortical)});
  }

  /// A penetrating branch from a cortical point toward the tumour, then branching on the shell.
  void grow_deep_branch(index_t cortical_points) {
    const Vector3d tc = m_g.tumour_centre;
    std::vector<index_t> candidates;
    for (index_t i = 0; i < cortical_points; ++i)
      if (m_tree.generation[std::size_t(i)] <= 2 &&
          m_tree.radius[std::size_t(i)] >= m_o.deep_radius)
        candidates.push_back(i);
    if (candidates.empty()) return;
    std::sort(candidates.begin(), candidates.end(), [&](index_t a, index_t b) {
      return (m_tree.points[std::size_t(a)] - tc).norm() <
             (m_tree.points[std::size_t(b)] - tc).norm();
    });
    candidates.resize(std::min<std::size_t>(candidates.size(), 40));
    const index_t start = candidates[std::size_t(
        std::uniform_int_distribution<int>(0, int(candidates.size()) - 1)(m_rng))];
    const int generation = m_tree.generation[std::size_t(start)] + 1;
    const Guide shell = random_guide(false);
    Vector3d p = m_tree.points[std::size_t(start)];
    Vector3d dir = (tc - p).normalized();
    const int max_steps = int((tc - p).norm() / m_o.step * 1.5) + 5;
    index_t prev = start;
    bool arrived = false;
    for (int k = 0; k < max_steps && !arrived; ++k) {
      dir = (dir + 0.35 * (tc - p).normalized()).normalized();
      dir = Eigen::AngleAxisd(deg(gaussian(m_o.wander_deg)), dir.unitOrthogonal()) * dir;
      Vector3d q = p + m_o.step * dir;
      if ((q - tc).norm() <= m_g.tumour_radius + shell.offset) {
        q = project(q, shell);
        arrived = true;
      }
      if (!valid(q)) break;
      prev = add_point(q, m_o.deep_radius, generation, prev);
      dir = (q - p).normalized();
      p = q;
    }
    if (!arrived || m_o.deep_generations == 0) return;
    const int cap = std::min(6, generation + m_o.deep_generations);
    BranchJob job{prev, dir, m_o.deep_radius, generation, cap, shell};
    std::vector<BranchJob> stack;
    split(prev, dir, job, stack);
    while (!stack.empty()) {
      const BranchJob next = stack.back();
      stack.pop_back();
      grow_branch(next, stack);
    }
  }

  const BrainShape& m_g;
  const VesselTreeOptions& m_o;
  std::mt19937 m_rng;
  VesselTree m_tree;
};

}  // namespace

VesselTree make_vessel_tree(const PhantomGeometry& geometry, const VesselTreeOptions& options) {
  const std::string bad_geometry = geometry.validate();
  BS_VERIFY(bad_geometry.empty(), "invalid phantom geometry: " << bad_geometry);
  return make_vessel_tree(brain_shape(geometry), options);
}

VesselTree make_vessel_tree(const BrainShape& shape, const VesselTreeOptions& options) {
  const std::string bad = options.validate();
  BS_VERIFY(bad.empty(), "invalid vessel tree options: " << bad);
  VesselTree tree = TreeGrower(shape, options).grow();
  tree.verify();
  return tree;
}

}  // namespace brainshift::data_synth
