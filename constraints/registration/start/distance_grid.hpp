#pragma once
/// @file
/// @brief The skeleton's truncated squared-distance map on a regular grid, shared by the global
/// start and the bulk-shift search (one copy; private to constraints/registration). Positions in
/// mm, world (RAS) frame. A grid of its own rather than imaging's sampler: the registration layer
/// does not depend on imaging (cmake/layering.cmake).

#include "core/config.hpp"
#include "core/geometry/skeleton.hpp"
#include "core/mapping/closest_point.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

namespace brainshift::constraints::detail {

/// Squared distance to the nearest skeleton segment (truncated at τ²), that segment (−1 beyond
/// τ) and the kernel κ_τ quantised to 0…255, on a regular grid.
class DistanceGrid {
 public:
  DistanceGrid(const core::Skeleton& s, const Vector3d& lo, const Vector3d& hi, double h,
               double tau)
      : m_lo(lo), m_h(h), m_tau2(tau * tau) {
    m_dims = (((hi - lo) / h).array().ceil().cast<int>() + 1).matrix();
    const auto n = static_cast<std::size_t>(m_dims.x()) * static_cast<std::size_t>(m_dims.y()) *
                   static_cast<std::size_t>(m_dims.z());
    m_d2.assign(n, static_cast<float>(m_tau2));
    m_seg.assign(n, -1);
    for (std::size_t si = 0; si < s.segments.size(); ++si) {
      const Vector3d a = s.points.row(s.segments[si][0]).transpose(),
                     b = s.points.row(s.segments[si][1]).transpose();
      const Eigen::Vector3i c0 = floor_cell(a.cwiseMin(b).array() - tau),
                            c1 = floor_cell(a.cwiseMax(b).array() + tau) + Eigen::Vector3i::Ones();
      const Eigen::Vector3i l = c0.cwiseMax(0), u = c1.cwiseMin(m_dims - Eigen::Vector3i::Ones());
      for (int z = l.z(); z <= u.z(); ++z)
        for (int y = l.y(); y <= u.y(); ++y)
          for (int x = l.x(); x <= u.x(); ++x) {
            const Vector3d q = m_lo + h * Vector3d(x, y, z);
            const double t = core::closest_point_on_segment(q, a, b);
            const auto e = static_cast<float>((q - (a + t * (b - a))).squaredNorm());
            const std::size_t k = index(x, y, z);
            if (e < m_d2[k]) {
              m_d2[k] = e;
              m_seg[k] = static_cast<std::int32_t>(si);
            }
          }
    }
    m_kernel.resize(n);
    for (std::size_t k = 0; k < n; ++k)
      m_kernel[k] =
          static_cast<std::uint8_t>(std::lround(255.0 * std::max(0.0, 1.0 - m_d2[k] / m_tau2)));
  }
  [[nodiscard]] const Eigen::Vector3i& dims() const { return m_dims; }
  [[nodiscard]] double spacing() const { return m_h; }
  [[nodiscard]] const std::uint8_t* kernel() const { return m_kernel.data(); }
  [[nodiscard]] std::size_t index(int x, int y, int z) const {
    return static_cast<std::size_t>(x) +
           static_cast<std::size_t>(m_dims.x()) *
               (static_cast<std::size_t>(y) +
                static_cast<std::size_t>(m_dims.y()) * static_cast<std::size_t>(z));
  }
  [[nodiscard]] Eigen::Vector3i nearest_cell(const Vector3d& q) const {
    return ((q - m_lo) / m_h).array().round().cast<int>();
  }
  [[nodiscard]] bool inside(const Eigen::Vector3i& c, int pad = 0) const {
    return (c.array() >= pad).all() && (c.array() < m_dims.array() - pad).all();
  }
  /// Squared distance at the voxel nearest q (coarse lookup), τ² outside the grid.
  [[nodiscard]] double nearest(const Vector3d& q) const {
    const Eigen::Vector3i c = nearest_cell(q);
    return inside(c) ? double(m_d2[index(c.x(), c.y(), c.z())]) : m_tau2;
  }
  /// Segment nearest to the voxel nearest q, −1 beyond τ or outside the grid.
  [[nodiscard]] std::int32_t segment(const Vector3d& q) const {
    const Eigen::Vector3i c = nearest_cell(q);
    return inside(c) ? m_seg[index(c.x(), c.y(), c.z())] : -1;
  }
  /// Trilinear squared distance, τ² outside the grid.
  [[nodiscard]] double trilinear(const Vector3d& q) const {
    const Vector3d g = (q - m_lo) / m_h;
    if (!g.allFinite()) return m_tau2;
    const Eigen::Vector3i c = g.array().floor().cast<int>();
    if ((c.array() < 0).any() || (c.array() + 1 >= m_dims.array()).any()) return m_tau2;
    const Vector3d f = g - c.cast<double>();
    double v = 0;
    for (int k = 0; k < 8; ++k) {
      const int dx = k & 1, dy = (k >> 1) & 1, dz = (k >> 2) & 1;
      const double w =
          (dx ? f.x() : 1 - f.x()) * (dy ? f.y() : 1 - f.y()) * (dz ? f.z() : 1 - f.z());
      v += w * m_d2[index(c.x() + dx, c.y() + dy, c.z() + dz)];
    }
    return v;
  }

 private:
  [[nodiscard]] Eigen::Vector3i floor_cell(const Vector3d& p) const {
    return ((p - m_lo) / m_h).array().floor().cast<int>();
  }
  Vector3d m_lo;
  double m_h;
  double m_tau2;
  Eigen::Vector3i m_dims;
  std::vector<float> m_d2;
  std::vector<std::int32_t> m_seg;
  std::vector<std::uint8_t> m_kernel;
};

}  // namespace brainshift::constraints::detail
