#include "constraints/registration/pairing.hpp"

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
  for (const auto& f : m_features)
    for (int k = 0; k < m_arity; ++k) {
      BS_VERIFY(f[k] >= 0 && f[k] < nv,
                "feature refers to vertex " << f[k] << ", outside [0, " << nv << ")");
    }
  MatrixX3d lo(static_cast<Eigen::Index>(m_features.size()), 3);
  MatrixX3d hi(lo.rows(), 3);
  for (std::size_t f = 0; f < m_features.size(); ++f) {
    const auto r = static_cast<Eigen::Index>(f);
    lo.row(r) = hi.row(r) = m_vertices.row(m_features[f][0]);
    for (int k = 1; k < m_arity; ++k) {
      lo.row(r) = lo.row(r).cwiseMin(m_vertices.row(m_features[f][k]));
      hi.row(r) = hi.row(r).cwiseMax(m_vertices.row(m_features[f][k]));
    }
  }
  m_grid = core::GridIndex(lo, hi);
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
  // Ties go to the lowest feature index (core::GridIndex::nearest).
  const auto hit =
      m_grid.nearest(q, max_distance, [&](index_t f) { return closest_on(f, q).distance; });
  if (!hit) return std::nullopt;
  return closest_on(hit->item, q);
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
