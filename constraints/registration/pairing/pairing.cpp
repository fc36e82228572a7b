#include "constraints/registration/pairing/pairing.hpp"

#include "core/error.hpp"
#include "core/mapping/closest_point.hpp"

#include <algorithm>
#include <cmath>

namespace brainshift::constraints {

FeatureIndex FeatureIndex::segments(ConstRef<MatrixX3d> vertices,
                                    const std::vector<std::array<index_t, 2>>& segments) {
  std::vector<std::array<index_t, 3>> f;
  f.reserve(segments.size());
  for (const auto& s : segments) f.push_back({s[0], s[1], -1});
  return FeatureIndex(vertices, std::move(f), 2);
}

FeatureIndex FeatureIndex::triangles(
    ConstRef<MatrixX3d> vertices,
    const Eigen::Matrix<index_t, Eigen::Dynamic, 3, Eigen::RowMajor>& tris) {
  std::vector<std::array<index_t, 3>> f(static_cast<std::size_t>(tris.rows()));
  for (Eigen::Index t = 0; t < tris.rows(); ++t) f[t] = {tris(t, 0), tris(t, 1), tris(t, 2)};
  return FeatureIndex(vertices, std::move(f), 3);
}

FeatureIndex::FeatureIndex(ConstRef<MatrixX3d> vertices,
                           std::vector<std::array<index_t, 3>> features, int arity)
    : m_vertices(vertices), m_features(std::move(features)), m_arity(arity) {
  BS_VERIFY(m_vertices.allFinite(), "feature vertices contain NaN or infinity");
  const auto nv = static_cast<index_t>(m_vertices.rows());
  double total = 0;
  for (const auto& f : m_features)
    for (int k = 0; k < m_arity; ++k) {
      BS_VERIFY(f[k] >= 0 && f[k] < nv,
                "feature refers to vertex " << f[k] << ", outside [0, " << nv << ")");
      total += (m_vertices.row(f[(k + 1) % m_arity]) - m_vertices.row(f[k])).norm();
    }
  if (m_features.empty()) return;
  const Vector3d lo = m_vertices.colwise().minCoeff().transpose();
  const Vector3d hi = m_vertices.colwise().maxCoeff().transpose();
  const double mean_edge = total / (m_arity * static_cast<double>(m_features.size()));
  // Cell ≈ mean edge, but no more than ~2M cells.
  m_cell = std::max({mean_edge, 1e-6, (hi - lo).maxCoeff() / 128.0});
  m_origin = lo;
  m_dims = (((hi - lo) / m_cell).array().floor().cast<int>() + 1).matrix();
  const auto cell_of = [&](const Vector3d& p) {
    return ((p - m_origin) / m_cell)
        .array()
        .floor()
        .cast<int>()
        .max(0)
        .min(m_dims.array() - 1)
        .matrix()
        .eval();
  };
  const std::size_t ncell = static_cast<std::size_t>(m_dims.x()) * m_dims.y() * m_dims.z();
  std::vector<std::vector<index_t>> buckets(ncell);
  for (std::size_t f = 0; f < m_features.size(); ++f) {
    Vector3d a = m_vertices.row(m_features[f][0]).transpose(), b = a;
    for (int k = 1; k < m_arity; ++k) {
      a = a.cwiseMin(m_vertices.row(m_features[f][k]).transpose());
      b = b.cwiseMax(m_vertices.row(m_features[f][k]).transpose());
    }
    const Eigen::Vector3i c0 = cell_of(a), c1 = cell_of(b);
    for (int z = c0.z(); z <= c1.z(); ++z)
      for (int y = c0.y(); y <= c1.y(); ++y)
        for (int x = c0.x(); x <= c1.x(); ++x)
          buckets[x + static_cast<std::size_t>(m_dims.x()) *
                          (y + static_cast<std::size_t>(m_dims.y()) * z)]
              .push_back(static_cast<index_t>(f));
  }
  m_cell_start.assign(ncell + 1, 0);
  for (std::size_t c = 0; c < ncell; ++c)
    m_cell_start[c + 1] = m_cell_start[c] + static_cast<index_t>(buckets[c].size());
  m_cell_features.reserve(static_cast<std::size_t>(m_cell_start.back()));
  for (const auto& b : buckets) m_cell_features.insert(m_cell_features.end(), b.begin(), b.end());
}

Pair FeatureIndex::closest_on(index_t f, const Vector3d& q) const {
  const auto& v = m_features[f];
  Pair p;
  p.feature = f;
  const Vector3d a = m_vertices.row(v[0]).transpose(), b = m_vertices.row(v[1]).transpose();
  if (m_arity == 2) {
    const double t = core::closest_point_on_segment(q, a, b);
    p.weights = Vector3d(1 - t, t, 0);
    p.closest = a + t * (b - a);
    const Vector3d d = b - a;
    p.direction = d.norm() > 0 ? Vector3d(d.normalized()) : Vector3d::UnitX();
  } else {
    const Vector3d c = m_vertices.row(v[2]).transpose();
    p.weights = core::closest_point_on_triangle(q, a, b, c);
    p.closest = p.weights[0] * a + p.weights[1] * b + p.weights[2] * c;
    const Vector3d n = (b - a).cross(c - a);
    p.direction = n.norm() > 0 ? Vector3d(n.normalized()) : Vector3d::UnitZ();
  }
  p.distance = (q - p.closest).norm();
  return p;
}

std::optional<Pair> FeatureIndex::nearest(const Vector3d& q, double max_distance) const {
  if (m_features.empty() || !q.allFinite()) return std::nullopt;
  const Eigen::Vector3i c = ((q - m_origin) / m_cell).array().floor().cast<int>();
  std::optional<Pair> best;
  double best_d = max_distance;
  const int max_ring = static_cast<int>(std::ceil(max_distance / m_cell)) + 1;
  for (int r = 0; r <= max_ring; ++r) {
    // Features in rings ≥ r are at least (r − 1)·cell away from q.
    if (best && (r - 1) * m_cell > best_d) break;
    for (int z = c.z() - r; z <= c.z() + r; ++z) {
      if (z < 0 || z >= m_dims.z()) continue;
      for (int y = c.y() - r; y <= c.y() + r; ++y) {
        if (y < 0 || y >= m_dims.y()) continue;
        for (int x = c.x() - r; x <= c.x() + r; ++x) {
          if (x < 0 || x >= m_dims.x()) continue;
          if (std::max({std::abs(x - c.x()), std::abs(y - c.y()), std::abs(z - c.z())}) != r)
            continue;
          const std::size_t cell = x + static_cast<std::size_t>(m_dims.x()) *
                                           (y + static_cast<std::size_t>(m_dims.y()) * z);
          for (index_t k = m_cell_start[cell]; k < m_cell_start[cell + 1]; ++k) {
            const Pair p = closest_on(m_cell_features[k], q);
            if (p.distance <= best_d && (!best || p.distance < best->distance)) {
              best = p;
              best_d = p.distance;
            }
          }
        }
      }
    }
  }
  return best;
}

std::vector<Pair> FeatureIndex::pair(ConstRef<MatrixX3d> queries, double max_distance) const {
  std::vector<Pair> out;
  out.reserve(static_cast<std::size_t>(queries.rows()));
  for (index_t i = 0; i < queries.rows(); ++i) {
    auto p = nearest(queries.row(i).transpose(), max_distance);
    if (p) {
      p->point = i;
      out.push_back(*p);
    }
  }
  return out;
}

}  // namespace brainshift::constraints
