#include "core/mapping/tet_locator.hpp"

#include "core/error.hpp"
#include "core/mapping/closest_point.hpp"

#include <cmath>
#include <limits>

namespace brainshift::core {
namespace {

/// Barycentric coordinates within which a point counts as inside a tetrahedron: a few ulps of
/// slack so that points on shared faces (and mesh-boundary points with rounding) are found.
constexpr double inside_tolerance = 1e-12;

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
    : m_nodes(nodes), m_tets(tets) {
  const index_t num_tets = static_cast<index_t>(m_tets.rows());
  const index_t num_nodes = static_cast<index_t>(m_nodes.rows());
  BS_VERIFY(m_tets.size() == 0 || (m_tets.minCoeff() >= 0 && m_tets.maxCoeff() < num_nodes),
            "TetLocator: a tetrahedron refers to a node outside [0, " << num_nodes << ")");
  BS_VERIFY(m_nodes.allFinite(), "TetLocator: the mesh has a non-finite node coordinate");
  MatrixX3d lo(num_tets, 3);
  MatrixX3d hi(num_tets, 3);
  for (index_t t = 0; t < num_tets; ++t) {
    lo.row(t) = hi.row(t) = m_nodes.row(m_tets(t, 0));
    for (int k = 1; k < 4; ++k) {
      lo.row(t) = lo.row(t).cwiseMin(m_nodes.row(m_tets(t, k)));
      hi.row(t) = hi.row(t).cwiseMax(m_nodes.row(m_tets(t, k)));
    }
  }
  m_grid = GridIndex(lo, hi);
}

std::optional<TetLocation> TetLocator::locate(const Vector3d& p, double max_distance) const {
  if (m_tets.rows() == 0 || !p.allFinite() || !(max_distance >= 0.0)) return std::nullopt;
  auto tet_nodes = [&](index_t t) {
    Eigen::Matrix<double, 4, 3> X;
    for (int k = 0; k < 4; ++k) X.row(k) = m_nodes.row(m_tets(t, k));
    return X;
  };
  // 1. Containing tetrahedron: all candidates are registered in p's own cell. Keep the one whose
  //    smallest barycentric coordinate is largest, so exact containment wins over tolerance.
  if (const auto cell = m_grid.cell_items(p); !cell.empty()) {
    index_t best = -1;
    Vector4d best_b;
    double best_min = -inside_tolerance;
    for (const index_t t : cell) {
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
  // 2. Nearest tetrahedron within max_distance: the tetrahedra whose box the search ball
  //    reaches, in ascending order.
  if (!std::isfinite(max_distance)) max_distance = std::numeric_limits<double>::max() / 4;
  const std::vector<index_t> candidates = m_grid.items_within(p, max_distance);
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
