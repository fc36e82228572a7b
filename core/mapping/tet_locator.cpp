#include "core/mapping/tet_locator.hpp"

#include "core/error.hpp"
#include "core/mapping/closest_point.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

namespace brainshift::core {
namespace {

/// Barycentric coordinates within which a point counts as inside a tetrahedron: a few ulps of
/// slack so that points on shared faces (and mesh-boundary points with rounding) are found.
constexpr double inside_tolerance = 1e-12;

/// Cap on the number of grid cells per tetrahedron: very flat meshes or a few huge elements must
/// not make the grid explode; the cell grows instead.
constexpr std::int64_t max_cells_per_tet = 8;

/// Exact distance from p to the solid tetrahedron X (rows = nodes) and the barycentric
/// coordinates of its closest point (p itself when inside).
TetLocation point_tet_distance(const Eigen::Matrix<double, 4, 3>& X, const Vector3d& p) {
  TetLocation loc;
  const Vector4d b = barycentric_coordinates(X, p);
  if (b.minCoeff() >= 0.0) {
    loc.barycentric = b;
    return loc;
  }
  // Outside: the closest point lies on one of the four faces.
  static constexpr int faces[4][3] = {{1, 2, 3}, {0, 2, 3}, {0, 1, 3}, {0, 1, 2}};
  loc.distance = std::numeric_limits<double>::infinity();
  for (const auto& f : faces) {
    const Vector3d w = closest_point_on_triangle(p, X.row(f[0]), X.row(f[1]), X.row(f[2]));
    const Vector3d q = w(0) * X.row(f[0]) + w(1) * X.row(f[1]) + w(2) * X.row(f[2]);
    const double d = (p - q).norm();
    if (d < loc.distance) {
      loc.distance = d;
      loc.barycentric.setZero();
      for (int k = 0; k < 3; ++k) loc.barycentric(f[k]) = w(k);
    }
  }
  return loc;
}

/// Squared distance from p to the axis-aligned box [lo, hi].
double squared_box_distance(const Vector3d& p, const Vector3d& lo, const Vector3d& hi) {
  return (p.cwiseMax(lo).cwiseMin(hi) - p).squaredNorm();
}

}  // namespace

Vector4d barycentric_coordinates(const Eigen::Matrix<double, 4, 3>& X, const Vector3d& p) {
  Matrix3d D;
  D.col(0) = (X.row(1) - X.row(0)).transpose();
  D.col(1) = (X.row(2) - X.row(0)).transpose();
  D.col(2) = (X.row(3) - X.row(0)).transpose();
  const Vector3d l = D.partialPivLu().solve(p - X.row(0).transpose());
  return {1.0 - l.sum(), l(0), l(1), l(2)};
}

TetLocator::TetLocator(ConstRef<MatrixX3d> nodes, ConstRef<MatrixX4i> tets)
    : m_nodes(nodes), m_tets(tets), m_origin(Vector3d::Zero()), m_dims(1, 1, 1) {
  const index_t num_tets = static_cast<index_t>(m_tets.rows());
  const index_t num_nodes = static_cast<index_t>(m_nodes.rows());
  BS_VERIFY(m_tets.size() == 0 || (m_tets.minCoeff() >= 0 && m_tets.maxCoeff() < num_nodes),
            "TetLocator: a tetrahedron refers to a node outside [0, " << num_nodes << ")");
  BS_VERIFY(m_nodes.allFinite(), "TetLocator: the mesh has a non-finite node coordinate");
  if (num_tets == 0) {
    m_cell_start.assign(2, 0);
    return;
  }
  // Bounding box of the used nodes and mean edge length.
  Vector3d lo = Vector3d::Constant(std::numeric_limits<double>::infinity());
  Vector3d hi = -lo;
  double edge_sum = 0.0;
  for (index_t t = 0; t < num_tets; ++t) {
    for (int i = 0; i < 4; ++i) {
      const Vector3d xi = m_nodes.row(m_tets(t, i));
      lo = lo.cwiseMin(xi);
      hi = hi.cwiseMax(xi);
      for (int j = i + 1; j < 4; ++j)
        edge_sum += (xi - m_nodes.row(m_tets(t, j)).transpose()).norm();
    }
  }
  const Vector3d extent = hi - lo;
  m_cell = edge_sum / (6.0 * num_tets);
  if (!(m_cell > 0.0)) m_cell = std::max(extent.maxCoeff(), 1.0);
  auto cells_for = [&](double cell) -> Eigen::Matrix<std::int64_t, 3, 1> {
    return (extent / cell).array().floor().cast<std::int64_t>() + 1;
  };
  const std::int64_t max_cells = max_cells_per_tet * std::int64_t{num_tets} + 1;
  for (auto n = cells_for(m_cell); n.prod() > max_cells; n = cells_for(m_cell)) {
    m_cell *= std::cbrt(static_cast<double>(n.prod()) / static_cast<double>(max_cells)) * 1.01;
  }
  m_origin = lo;
  m_dims = cells_for(m_cell).cast<int>();

  auto cell_of = [&](const Vector3d& x) {
    Eigen::Vector3i c;
    for (int a = 0; a < 3; ++a) {
      const double f = std::floor((x(a) - m_origin(a)) / m_cell);
      c(a) = static_cast<int>(std::clamp(f, 0.0, static_cast<double>(m_dims(a) - 1)));
    }
    return c;
  };
  auto for_each_cell = [&](index_t t, auto&& visit) {
    const Eigen::Matrix<double, 4, 3> X = [&] {
      Eigen::Matrix<double, 4, 3> Y;
      for (int k = 0; k < 4; ++k) Y.row(k) = m_nodes.row(m_tets(t, k));
      return Y;
    }();
    const Eigen::Vector3i c0 = cell_of(X.colwise().minCoeff().transpose());
    const Eigen::Vector3i c1 = cell_of(X.colwise().maxCoeff().transpose());
    for (int k = c0.z(); k <= c1.z(); ++k)
      for (int j = c0.y(); j <= c1.y(); ++j)
        for (int i = c0.x(); i <= c1.x(); ++i) visit(i + m_dims.x() * (j + m_dims.y() * k));
  };
  // CSR: count, prefix-sum, fill.
  const std::size_t num_cells = static_cast<std::size_t>(m_dims.cast<std::int64_t>().prod());
  m_cell_start.assign(num_cells + 1, 0);
  for (index_t t = 0; t < num_tets; ++t) for_each_cell(t, [&](int c) { ++m_cell_start[c + 1]; });
  for (std::size_t c = 0; c < num_cells; ++c) m_cell_start[c + 1] += m_cell_start[c];
  m_cell_tets.resize(static_cast<std::size_t>(m_cell_start.back()));
  std::vector<index_t> fill(m_cell_start.begin(), m_cell_start.end() - 1);
  for (index_t t = 0; t < num_tets; ++t)
    for_each_cell(t, [&](int c) { m_cell_tets[fill[c]++] = t; });
}

std::optional<TetLocation> TetLocator::locate(const Vector3d& p, double max_distance) const {
  if (m_tets.rows() == 0 || !p.allFinite() || !(max_distance >= 0.0)) return std::nullopt;
  auto tet_nodes = [&](index_t t) {
    Eigen::Matrix<double, 4, 3> X;
    for (int k = 0; k < 4; ++k) X.row(k) = m_nodes.row(m_tets(t, k));
    return X;
  };
  auto cell_range = [&](double margin, Eigen::Vector3i& c0, Eigen::Vector3i& c1) {
    for (int a = 0; a < 3; ++a) {
      const double f0 = std::floor((p(a) - margin - m_origin(a)) / m_cell);
      const double f1 = std::floor((p(a) + margin - m_origin(a)) / m_cell);
      if (f1 < 0.0 || f0 > m_dims(a) - 1) return false;
      c0(a) = static_cast<int>(std::max(f0, 0.0));
      c1(a) = static_cast<int>(std::min(f1, static_cast<double>(m_dims(a) - 1)));
    }
    return true;
  };
  Eigen::Vector3i c0;
  Eigen::Vector3i c1;
  // 1. Containing tetrahedron: all candidates are registered in p's own cell. Keep the one whose
  //    smallest barycentric coordinate is largest, so exact containment wins over tolerance.
  if (cell_range(0.0, c0, c1)) {
    const int c = c0.x() + m_dims.x() * (c0.y() + m_dims.y() * c0.z());
    index_t best = -1;
    Vector4d best_b;
    double best_min = -inside_tolerance;
    for (index_t k = m_cell_start[c]; k < m_cell_start[c + 1]; ++k) {
      const index_t t = m_cell_tets[k];
      const Vector4d b = barycentric_coordinates(tet_nodes(t), p);
      if (b.minCoeff() >= best_min) {
        best = t;
        best_b = b;
        best_min = b.minCoeff();
        if (best_min >= 0.0) break;
      }
    }
    if (best >= 0) {
      TetLocation loc;
      loc.tet = best;
      loc.barycentric = best_b.cwiseMax(0.0);
      loc.barycentric /= loc.barycentric.sum();
      return loc;
    }
  }
  // 2. Nearest tetrahedron within max_distance, over the cells the search ball touches.
  if (!std::isfinite(max_distance)) max_distance = std::numeric_limits<double>::max() / 4;
  if (!cell_range(max_distance, c0, c1)) return std::nullopt;
  std::vector<index_t> candidates;
  for (int k = c0.z(); k <= c1.z(); ++k)
    for (int j = c0.y(); j <= c1.y(); ++j)
      for (int i = c0.x(); i <= c1.x(); ++i) {
        const int c = i + m_dims.x() * (j + m_dims.y() * k);
        candidates.insert(candidates.end(), m_cell_tets.begin() + m_cell_start[c],
                          m_cell_tets.begin() + m_cell_start[c + 1]);
      }
  std::sort(candidates.begin(), candidates.end());
  candidates.erase(std::unique(candidates.begin(), candidates.end()), candidates.end());
  std::optional<TetLocation> best;
  double best_distance = max_distance;
  for (const index_t t : candidates) {
    const Eigen::Matrix<double, 4, 3> X = tet_nodes(t);
    const double box2 = squared_box_distance(p, X.colwise().minCoeff().transpose(),
                                             X.colwise().maxCoeff().transpose());
    if (box2 > best_distance * best_distance) continue;
    TetLocation loc = point_tet_distance(X, p);
    if (loc.distance <= best_distance) {
      best_distance = loc.distance;
      loc.tet = t;
      best = loc;
    }
  }
  return best;
}

}  // namespace brainshift::core
