#include "constraints/registration/pairing/filtering.hpp"

#include "core/error.hpp"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <unordered_map>

namespace brainshift::constraints {

std::string FilterOptions::validate() const {
  if (!(median_threshold_mm >= 0)) return "filter median_threshold_mm must be ≥ 0";
  if (!(min_distance_mm >= 0)) return "filter min_distance_mm must be ≥ 0";
  if (!(max_angle_deg > 0)) return "filter max_angle_deg must be > 0";
  return {};
}

std::vector<Vector3d> local_directions(ConstRef<MatrixX3d> points, double radius) {
  const auto n = points.rows();
  std::vector<Vector3d> dir(static_cast<std::size_t>(n), Vector3d::Zero());
  const double r2 = radius * radius;
  for (Eigen::Index i = 0; i < n; ++i) {
    Vector3d mean = Vector3d::Zero();
    Matrix3d second = Matrix3d::Zero();
    int count = 0;
    for (Eigen::Index j = 0; j < n; ++j) {
      const Vector3d d = (points.row(j) - points.row(i)).transpose();
      if (d.squaredNorm() > r2) continue;
      mean += d;
      second += d * d.transpose();
      ++count;
    }
    if (count < 3) continue;
    mean /= count;
    const Matrix3d cov = second / count - mean * mean.transpose();
    const Eigen::SelfAdjointEigenSolver<Matrix3d> es(cov);
    if (es.eigenvalues()(2) >= 2.0 * es.eigenvalues()(1)) dir[i] = es.eigenvectors().col(2);
  }
  return dir;
}

std::vector<Pair> filter_pairs(std::vector<Pair> pairs, const std::vector<Vector3d>& directions,
                               const std::vector<index_t>& tet_of_pair,
                               const FilterOptions& options, FilterReport* report) {
  const std::string invalid = options.validate();
  BS_VERIFY(invalid.empty(), invalid);
  BS_VERIFY(
      tet_of_pair.empty() || tet_of_pair.size() == pairs.size(),
      "tet_of_pair has " << tet_of_pair.size() << " entries for " << pairs.size() << " pairs");
  FilterReport rep;
  rep.input = static_cast<index_t>(pairs.size());
  std::vector<index_t> tets = tet_of_pair;
  auto keep_if = [&](auto pred, index_t& dropped) {
    std::vector<Pair> kept;
    std::vector<index_t> kept_tets;
    for (std::size_t i = 0; i < pairs.size(); ++i) {
      if (pred(pairs[i])) {
        kept.push_back(pairs[i]);
        if (!tets.empty()) kept_tets.push_back(tets[i]);
      } else {
        ++dropped;
      }
    }
    pairs = std::move(kept);
    if (!tets.empty()) tets = std::move(kept_tets);
  };

  // 1. One point per feature: the nearest.
  if (options.one_per_feature) {
    std::unordered_map<index_t, std::size_t> best;
    for (std::size_t i = 0; i < pairs.size(); ++i) {
      auto [it, inserted] = best.try_emplace(pairs[i].feature, i);
      if (!inserted && pairs[i].distance < pairs[it->second].distance) it->second = i;
    }
    keep_if([&](const Pair& p) { return &pairs[best.at(p.feature)] == &p; }, rep.duplicate_feature);
  }
  // 2. Distance window.
  if (!pairs.empty()) {
    std::vector<double> d;
    for (const Pair& p : pairs) d.push_back(p.distance);
    std::nth_element(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(d.size() / 2), d.end());
    rep.median_distance = d[d.size() / 2];
    const double far = rep.median_distance + options.median_threshold_mm;
    keep_if([&](const Pair& p) { return p.distance <= far; }, rep.too_far);
    keep_if([&](const Pair& p) { return p.distance >= options.min_distance_mm; }, rep.too_near);
  }
  // 3. Direction agreement (segments: tangent vs local direction of the intra-operative points).
  if (!directions.empty() && options.max_angle_deg < 90.0) {
    const double cos_max = std::cos(options.max_angle_deg * std::numbers::pi / 180.0);
    keep_if(
        [&](const Pair& p) {
          BS_VERIFY(p.point >= 0 && static_cast<std::size_t>(p.point) < directions.size(),
                    "pair refers to point " << p.point << " without a local direction");
          const Vector3d& d = directions[p.point];
          return d.isZero() || std::abs(d.dot(p.direction)) >= cos_max;
        },
        rep.direction);
  }
  // 4. At most max_per_tet per tetrahedron, nearest first.
  if (!tets.empty() && options.max_per_tet > 0) {
    std::vector<std::size_t> order(pairs.size());
    for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
    std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
      return pairs[a].distance < pairs[b].distance;
    });
    std::unordered_map<index_t, int> used;
    std::vector<char> keep(pairs.size(), 0);
    for (std::size_t i : order)
      if (++used[tets[i]] <= options.max_per_tet) keep[i] = 1;
    std::size_t k = 0;
    keep_if([&](const Pair&) { return keep[k++] != 0; }, rep.subsampled);
  }
  std::sort(pairs.begin(), pairs.end(),
            [](const Pair& a, const Pair& b) { return a.point < b.point; });
  rep.kept = static_cast<index_t>(pairs.size());
  if (report) *report = rep;
  return pairs;
}

}  // namespace brainshift::constraints
