#pragma once
/// @file
/// @brief Nearest node of a fixed point set (mesh nodes, mm) by a uniform grid: the bulk basis
/// (global_start.hpp, load_basis) looks up 500 points among 17k nodes twice per registration.

#include "core/config.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <vector>

namespace brainshift::constraints {

/// The nearest node of a point set: a uniform grid of about two nodes per cell, searched in
/// growing shells of cells until no closer node can remain. Ties go to the lowest index, as a
/// linear scan's first minimum would (same answer, O(1) per query instead of O(#nodes)).
class NearestNode {
 public:
  /// @param[in] nodes #N×3 positions (mm); kept by reference, must outlive this object.
  explicit NearestNode(const MatrixX3d& nodes) : m_nodes(nodes) {
    m_lo = nodes.colwise().minCoeff().transpose();
    const Vector3d extent =
        (nodes.colwise().maxCoeff().transpose() - m_lo).cwiseMax(Vector3d::Constant(1e-9));
    const double cells = std::max(1.0, static_cast<double>(nodes.rows()) / 2.0);
    m_h = std::cbrt(extent.prod() / cells);
    if (!(m_h > 0) || !std::isfinite(m_h)) m_h = std::max(extent.maxCoeff(), 1e-9);
    for (int k = 0; k < 3; ++k)
      m_dim[k] = std::clamp(static_cast<int>(std::ceil(extent[k] / m_h)), 1, 1024);
    m_start.assign(static_cast<std::size_t>(m_dim[0]) * m_dim[1] * m_dim[2] + 1, 0);
    std::vector<std::size_t> cell_of(static_cast<std::size_t>(nodes.rows()));
    for (Eigen::Index i = 0; i < nodes.rows(); ++i) {
      cell_of[static_cast<std::size_t>(i)] = flat(cell(nodes.row(i).transpose()));
      ++m_start[cell_of[static_cast<std::size_t>(i)] + 1];
    }
    for (std::size_t c = 1; c < m_start.size(); ++c) m_start[c] += m_start[c - 1];
    m_index.resize(static_cast<std::size_t>(nodes.rows()));
    std::vector<std::size_t> fill(m_start.begin(), m_start.end() - 1);
    for (Eigen::Index i = 0; i < nodes.rows(); ++i)  // ascending within each cell
      m_index[fill[cell_of[static_cast<std::size_t>(i)]]++] = i;
  }

  /// Index of the node nearest to p (the lowest index among equals; 0 for a NaN point).
  [[nodiscard]] Eigen::Index nearest(const Vector3d& p) const {
    const std::array<int, 3> c = cell(p);
    Eigen::Index best = -1;
    double best_d2 = std::numeric_limits<double>::infinity();
    const int max_r = std::max({m_dim[0], m_dim[1], m_dim[2]});
    for (int r = 0; r <= max_r; ++r) {
      // Every node of a cell at Chebyshev ring r lies at least (r − 1) h away from p (p may be
      // outside the grid, clamped into it: farther still). Stop once that exceeds the best.
      if (best >= 0 && r >= 1) {
        const double reach = (r - 1) * m_h;
        if (reach * reach > best_d2) break;
      }
      for (int z = c[2] - r; z <= c[2] + r; ++z)
        for (int y = c[1] - r; y <= c[1] + r; ++y) {
          // Inside the ring's faces only x = ±r belongs to the ring.
          const bool face = std::abs(z - c[2]) == r || std::abs(y - c[1]) == r;
          for (int x = c[0] - r; x <= c[0] + r; x += (face || r == 0) ? 1 : 2 * r) {
            if (x < 0 || y < 0 || z < 0 || x >= m_dim[0] || y >= m_dim[1] || z >= m_dim[2])
              continue;
            const std::size_t f = flat({x, y, z});
            for (std::size_t k = m_start[f]; k < m_start[f + 1]; ++k) {
              const Eigen::Index i = m_index[k];
              const double d2 = (m_nodes.row(i) - p.transpose()).squaredNorm();
              if (d2 < best_d2 || (d2 == best_d2 && i < best)) {
                best_d2 = d2;
                best = i;
              }
            }
          }
        }
    }
    return std::max<Eigen::Index>(best, 0);  // 0 when nothing compares (a NaN point)
  }

 private:
  [[nodiscard]] std::array<int, 3> cell(const Vector3d& p) const {
    std::array<int, 3> c{};
    for (int k = 0; k < 3; ++k) {
      const double v = std::floor((p[k] - m_lo[k]) / m_h);
      c[static_cast<std::size_t>(k)] =
          std::isfinite(v) ? static_cast<int>(std::clamp(v, 0.0, m_dim[k] - 1.0)) : 0;
    }
    return c;
  }
  [[nodiscard]] std::size_t flat(const std::array<int, 3>& c) const {
    return (static_cast<std::size_t>(c[2]) * m_dim[1] + c[1]) * m_dim[0] + c[0];
  }

  const MatrixX3d& m_nodes;
  Vector3d m_lo;
  double m_h = 1.0;
  std::array<int, 3> m_dim{1, 1, 1};
  std::vector<std::size_t> m_start;
  std::vector<Eigen::Index> m_index;
};

}  // namespace brainshift::constraints
