#pragma once
/// @file
/// @brief The skeleton's truncated squared-distance map on a regular grid, shared by the global
/// start and the bulk-shift search (one copy; private to constraints/registration). Positions in
/// mm, world (RAS) frame. A grid of its own rather than imaging's sampler: the registration layer
/// does not depend on imaging (cmake/layering.cmake).

#include "core/config.hpp"
#include "core/error.hpp"
#include "core/geometry/skeleton.hpp"
#include "core/mapping/closest_point.hpp"
#include "core/parallel.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

namespace brainshift::constraints::detail {

/// std::round(v) (halves away from zero), exactly and without a branch or a library call, for
/// |v| ≤ 2³⁰; beyond, ±2³⁰ (a voxel far outside any grid). v − trunc(v) is exact in double. The
/// searches round millions of positions to voxels: std::round's call, or a branch on the
/// fraction (mispredicted half the time), was most of their cost.
[[nodiscard]] inline int round_half_away(double v) {
  constexpr double far = 1073741824.0;  // 2³⁰
  v = std::clamp(v, -far, far);
  const auto t = static_cast<int>(v);  // truncation towards zero
  const double f = v - static_cast<double>(t);
  return t + static_cast<int>(f >= 0.5) - static_cast<int>(f <= -0.5);
}

/// Squared distance to the nearest skeleton segment (truncated at τ²), that segment (−1 beyond
/// τ) and the kernel κ_τ quantised to 0…255, on a regular grid.
class DistanceGrid {
 public:
  /// The grid of voxels lo + h·(x, y, z) covering [lo, hi]. With `stored_near_skeleton`, only the
  /// voxels within τ (and a cell) of the skeleton's segments are stored: every other voxel of the
  /// grid holds τ², −1 and κ = 0 anyway, so nearest(), segment() and trilinear() answer exactly as
  /// the whole grid would, for a fraction of the memory when the grid is much larger than the
  /// skeleton (the bulk search's box grows with every shift it tries). kernel() and index() are
  /// then unavailable (the global start, which reads the kernel directly, stores the whole grid).
  DistanceGrid(const core::Skeleton& s, const Vector3d& lo, const Vector3d& hi, double h,
               double tau, bool stored_near_skeleton = false)
      : m_lo(lo), m_h(h), m_tau2(tau * tau) {
    m_dims = (((hi - lo) / h).array().ceil().cast<int>() + 1).matrix();
    m_w0.setZero();
    m_wd = m_dims;
    if (stored_near_skeleton) {
      Eigen::Vector3i c0 = m_dims, c1 = Eigen::Vector3i::Constant(-1);
      for (const auto& seg : s.segments) {
        const Vector3d a = s.points.row(seg[0]).transpose(), b = s.points.row(seg[1]).transpose();
        c0 = c0.cwiseMin(floor_cell(a.cwiseMin(b).array() - tau));
        c1 = c1.cwiseMax(floor_cell(a.cwiseMax(b).array() + tau) + Eigen::Vector3i::Ones());
      }
      m_w0 = c0.cwiseMax(0);
      m_wd = (c1.cwiseMin(m_dims - Eigen::Vector3i::Ones()) - m_w0 + Eigen::Vector3i::Ones())
                 .cwiseMax(0);
    }
    const auto n = static_cast<std::size_t>(m_wd.x()) * static_cast<std::size_t>(m_wd.y()) *
                   static_cast<std::size_t>(m_wd.z());
    m_d2.assign(n, static_cast<float>(m_tau2));
    m_seg.assign(n, -1);
    // One z-slab of the store per chunk, on the idle cores, each through every segment in order:
    // each voxel gets the same minimum, and the same (first) nearest segment, as in one pass.
    const auto slabs = static_cast<std::size_t>(std::clamp(m_wd.z(), 0, 8));
    core::parallel_chunks(slabs, core::hardware_threads(4), [&](std::size_t c) {
      const auto wz = static_cast<std::size_t>(m_wd.z());
      const int z0 = m_w0.z() + static_cast<int>(c * wz / slabs),
                z1 = m_w0.z() + static_cast<int>((c + 1) * wz / slabs) - 1;
      for (std::size_t si = 0; si < s.segments.size(); ++si) {
        const Vector3d a = s.points.row(s.segments[si][0]).transpose(),
                       b = s.points.row(s.segments[si][1]).transpose();
        const Eigen::Vector3i c0 = floor_cell(a.cwiseMin(b).array() - tau),
                              c1 =
                                  floor_cell(a.cwiseMax(b).array() + tau) + Eigen::Vector3i::Ones();
        const Eigen::Vector3i l = c0.cwiseMax(m_w0),
                              u = c1.cwiseMin(m_w0 + m_wd - Eigen::Vector3i::Ones());
        for (int z = std::max(l.z(), z0); z <= std::min(u.z(), z1); ++z)
          for (int y = l.y(); y <= u.y(); ++y)
            for (int x = l.x(); x <= u.x(); ++x) {
              const Vector3d q = m_lo + h * Vector3d(x, y, z);
              const double t = core::closest_point_on_segment(q, a, b);
              const auto e = static_cast<float>((q - (a + t * (b - a))).squaredNorm());
              const std::size_t k = stored(x, y, z);
              if (e < m_d2[k]) {
                m_d2[k] = e;
                m_seg[k] = static_cast<std::int32_t>(si);
              }
            }
      }
    });
    if (!whole()) {  // the bulk search's table: a mask of the voxels within τ, no kernel
      m_within.assign((n + 63) / 64, 0);
      for (std::size_t k = 0; k < n; ++k)
        if (double(m_d2[k]) < m_tau2) m_within[k >> 6] |= std::uint64_t{1} << (k & 63);
      return;
    }
    m_kernel.resize(n);
    for (std::size_t k = 0; k < n; ++k)
      m_kernel[k] =
          static_cast<std::uint8_t>(std::lround(255.0 * std::max(0.0, 1.0 - m_d2[k] / m_tau2)));
  }
  [[nodiscard]] const Eigen::Vector3i& dims() const { return m_dims; }
  [[nodiscard]] double spacing() const { return m_h; }
  /// κ quantised, the whole grid (only when it is stored whole).
  [[nodiscard]] const std::uint8_t* kernel() const {
    BS_ASSERT(whole(), "the distance grid is stored near the skeleton only");
    return m_kernel.data();
  }
  /// Offset of voxel (x, y, z) in kernel() (only when the grid is stored whole).
  [[nodiscard]] std::size_t index(int x, int y, int z) const {
    BS_ASSERT(whole(), "the distance grid is stored near the skeleton only");
    return stored(x, y, z);
  }
  [[nodiscard]] Eigen::Vector3i nearest_cell(const Vector3d& q) const {
    const Vector3d g = (q - m_lo) / m_h;
    return {round_half_away(g.x()), round_half_away(g.y()), round_half_away(g.z())};
  }
  [[nodiscard]] bool inside(const Eigen::Vector3i& c, int pad = 0) const {
    return (c.array() >= pad).all() && (c.array() < m_dims.array() - pad).all();
  }
  /// Squared distance at the voxel nearest q (coarse lookup), τ² outside the grid.
  [[nodiscard]] double nearest(const Vector3d& q) const {
    const Eigen::Vector3i c = nearest_cell(q);
    return inside(c) ? double(d2_at(c.x(), c.y(), c.z())) : m_tau2;
  }
  /// Whether the voxel nearest q lies within τ of the skeleton (its squared distance below τ²),
  /// and if so that squared distance, as nearest() gives it. Elsewhere nearest() is ≥ τ², so the
  /// kernel 1 − d²/τ² is ≤ 0 there: the bulk search skips those voxels, which are most of them,
  /// on a bit mask without reading the distance table (much larger than the caches).
  [[nodiscard]] bool nearest_within_tau(const Vector3d& q, double& d2) const {
    const Eigen::Vector3i c = nearest_cell(q);
    if (!in_store(c.x(), c.y(), c.z())) return false;  // outside the store: τ² (or the grid)
    const std::size_t k = stored(c.x(), c.y(), c.z());
    if (whole()) {  // no mask (the global start's grid): the table itself
      d2 = m_d2[k];
      return d2 < m_tau2;
    }
    if (!((m_within[k >> 6] >> (k & 63)) & 1U)) return false;
    d2 = m_d2[k];
    return true;
  }
  /// Segment nearest to the voxel nearest q, −1 beyond τ or outside the grid.
  [[nodiscard]] std::int32_t segment(const Vector3d& q) const {
    const Eigen::Vector3i c = nearest_cell(q);
    return inside(c) && in_store(c.x(), c.y(), c.z()) ? m_seg[stored(c.x(), c.y(), c.z())] : -1;
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
      v += w * d2_at(c.x() + dx, c.y() + dy, c.z() + dz);
    }
    return v;
  }

 private:
  [[nodiscard]] bool whole() const { return m_w0.isZero() && m_wd == m_dims; }
  [[nodiscard]] bool in_store(int x, int y, int z) const {
    return x >= m_w0.x() && y >= m_w0.y() && z >= m_w0.z() && x < m_w0.x() + m_wd.x() &&
           y < m_w0.y() + m_wd.y() && z < m_w0.z() + m_wd.z();
  }
  /// Offset of a stored voxel (grid indices).
  [[nodiscard]] std::size_t stored(int x, int y, int z) const {
    return static_cast<std::size_t>(x - m_w0.x()) +
           static_cast<std::size_t>(m_wd.x()) *
               (static_cast<std::size_t>(y - m_w0.y()) +
                static_cast<std::size_t>(m_wd.y()) * static_cast<std::size_t>(z - m_w0.z()));
  }
  /// The squared distance of a voxel of the grid: stored, or the τ² every unstored voxel holds
  /// (as the float a stored one would, so that trilinear() sums the same numbers either way).
  [[nodiscard]] float d2_at(int x, int y, int z) const {
    return in_store(x, y, z) ? m_d2[stored(x, y, z)] : static_cast<float>(m_tau2);
  }
  [[nodiscard]] Eigen::Vector3i floor_cell(const Vector3d& p) const {
    return ((p - m_lo) / m_h).array().floor().cast<int>();
  }
  Vector3d m_lo;
  double m_h;
  double m_tau2;
  Eigen::Vector3i m_dims;
  Eigen::Vector3i m_w0,
      m_wd;  ///< the stored window: first voxel and size (the whole grid by default)
  std::vector<float> m_d2;
  std::vector<std::int32_t> m_seg;
  /// Bit k: stored voxel k's squared distance is below τ² (only when stored near the skeleton).
  std::vector<std::uint64_t> m_within;
  std::vector<std::uint8_t> m_kernel;
};

}  // namespace brainshift::constraints::detail
