#include "core/spatial/grid_index.hpp"

#include "core/error.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

namespace brainshift::core {
namespace {

/// Most cells per item (the grid's memory bound; see the header's cell-size heuristic).
constexpr double max_cells_per_item = 8.0;

/// Number of cells of a grid with cell size h over `extent`, as a double (no overflow).
double cell_count(const Vector3d& extent, double h) {
  double n = 1.0;
  for (int a = 0; a < 3; ++a) n *= std::floor(extent(a) / h) + 1.0;
  return n;
}

/// floor(x) clamped into [0, n − 1], computed in double so that huge or infinite x cannot
/// overflow the integer conversion.
int clamp_floor(double x, int n) {
  return static_cast<int>(std::clamp(std::floor(x), 0.0, static_cast<double>(n - 1)));
}

}  // namespace

GridIndex::GridIndex(ConstRef<MatrixX3d> box_lo, ConstRef<MatrixX3d> box_hi)
    : m_lo(box_lo), m_hi(box_hi) {
  BS_VERIFY(m_lo.rows() == m_hi.rows(), "GridIndex: " << m_lo.rows() << " lower corners but "
                                                      << m_hi.rows() << " upper corners");
  BS_VERIFY(m_lo.allFinite() && m_hi.allFinite(), "GridIndex: a box corner is not finite");
  const index_t n = size();
  for (index_t i = 0; i < n; ++i)
    BS_VERIFY((m_hi.row(i).array() >= m_lo.row(i).array()).all(),
              "GridIndex: box " << i << " has an upper corner below its lower corner");
  if (n == 0) return;

  m_origin = m_lo.colwise().minCoeff().transpose();
  const Vector3d extent = m_hi.colwise().maxCoeff().transpose() - m_origin;
  // The one cell-size heuristic: mean longest box side, grown to at most 8·#items + 1 cells.
  const double max_cells = max_cells_per_item * n + 1.0;
  m_cell = (m_hi - m_lo).rowwise().maxCoeff().mean();
  if (!(m_cell > 0.0)) m_cell = extent.maxCoeff() / std::cbrt(max_cells);
  if (!(m_cell > 0.0)) m_cell = 1.0;  // every box at one point: one cell
  for (double cells = cell_count(extent, m_cell); cells > max_cells;
       cells = cell_count(extent, m_cell))
    m_cell *= std::cbrt(cells / max_cells) * 1.01;
  for (int a = 0; a < 3; ++a) m_dims(a) = static_cast<int>(std::floor(extent(a) / m_cell)) + 1;

  // CSR: count, prefix-sum, fill (items ascending within each cell).
  const std::size_t num_cells = static_cast<std::size_t>(m_dims.cast<std::int64_t>().prod());
  m_cell_start.assign(num_cells + 1, 0);
  const auto for_each_cell = [&](index_t i, auto&& visit) {
    const Eigen::Vector3i c0 = clamped_cell(m_lo.row(i).transpose());
    const Eigen::Vector3i c1 = clamped_cell(m_hi.row(i).transpose());
    for (int z = c0.z(); z <= c1.z(); ++z)
      for (int y = c0.y(); y <= c1.y(); ++y)
        for (int x = c0.x(); x <= c1.x(); ++x) visit(cell_index(x, y, z));
  };
  for (index_t i = 0; i < n; ++i) for_each_cell(i, [&](std::size_t c) { ++m_cell_start[c + 1]; });
  for (std::size_t c = 0; c < num_cells; ++c) m_cell_start[c + 1] += m_cell_start[c];
  m_cell_items.resize(static_cast<std::size_t>(m_cell_start.back()));
  std::vector<index_t> fill(m_cell_start.begin(), m_cell_start.end() - 1);
  for (index_t i = 0; i < n; ++i)
    for_each_cell(i, [&](std::size_t c) { m_cell_items[static_cast<std::size_t>(fill[c]++)] = i; });
}

GridIndex GridIndex::of_points(ConstRef<MatrixX3d> points) { return {points, points}; }

Eigen::Vector3i GridIndex::clamped_cell(const Vector3d& x) const {
  Eigen::Vector3i c;
  for (int a = 0; a < 3; ++a) c(a) = clamp_floor((x(a) - m_origin(a)) / m_cell, m_dims(a));
  return c;
}

std::size_t GridIndex::cell_index(int i, int j, int k) const {
  return static_cast<std::size_t>(i) +
         static_cast<std::size_t>(m_dims.x()) *
             (static_cast<std::size_t>(j) + static_cast<std::size_t>(m_dims.y()) * k);
}

double GridIndex::box_squared_distance(index_t item, const Vector3d& p) const {
  const Vector3d lo = m_lo.row(item).transpose();
  const Vector3d hi = m_hi.row(item).transpose();
  return (p.cwiseMax(lo).cwiseMin(hi) - p).squaredNorm();
}

std::span<const index_t> GridIndex::cell_items(const Vector3d& p) const {
  if (size() == 0 || !p.allFinite()) return {};
  Eigen::Vector3i c;
  for (int a = 0; a < 3; ++a) {
    const double f = std::floor((p(a) - m_origin(a)) / m_cell);
    if (f < 0.0 || f > m_dims(a) - 1) return {};
    c(a) = static_cast<int>(f);
  }
  const std::size_t cell = cell_index(c.x(), c.y(), c.z());
  return {m_cell_items.data() + m_cell_start[cell],
          static_cast<std::size_t>(m_cell_start[cell + 1] - m_cell_start[cell])};
}

std::vector<index_t> GridIndex::items_within(const Vector3d& p, double radius) const {
  std::vector<index_t> out;
  if (size() == 0 || !p.allFinite() || !(radius >= 0.0)) return out;
  Eigen::Vector3i c0;
  Eigen::Vector3i c1;
  for (int a = 0; a < 3; ++a) {
    const double f0 = std::floor((p(a) - radius - m_origin(a)) / m_cell);
    const double f1 = std::floor((p(a) + radius - m_origin(a)) / m_cell);
    if (f1 < 0.0 || f0 > m_dims(a) - 1) return out;
    c0(a) = clamp_floor(f0, m_dims(a));
    c1(a) = clamp_floor(f1, m_dims(a));
  }
  const double r2 = radius * radius;
  for (int z = c0.z(); z <= c1.z(); ++z)
    for (int y = c0.y(); y <= c1.y(); ++y)
      for (int x = c0.x(); x <= c1.x(); ++x) {
        const std::size_t cell = cell_index(x, y, z);
        for (index_t k = m_cell_start[cell]; k < m_cell_start[cell + 1]; ++k) {
          const index_t i = m_cell_items[static_cast<std::size_t>(k)];
          if (box_squared_distance(i, p) <= r2) out.push_back(i);
        }
      }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

std::optional<GridNearest> GridIndex::nearest(const Vector3d& p, double max_distance,
                                              DistanceRef distance) const {
  if (size() == 0 || !p.allFinite() || !(max_distance >= 0.0)) return std::nullopt;
  const Eigen::Vector3i c = clamped_cell(p);
  GridNearest best{-1, std::numeric_limits<double>::infinity()};
  // Rounding of the cell bounds: stop a shell later rather than miss an item by an ulp.
  const double slack = 1e-9 * m_cell;
  const auto visit_cell = [&](int x, int y, int z) {
    const std::size_t cell = cell_index(x, y, z);
    const double limit = std::min(best.distance, max_distance);
    // Skip only boxes clearly farther than the limit: an item can tie the best at its box's
    // distance (a shared vertex at a box corner), and the squared comparison rounds either way;
    // skipping it would give the tie to whichever item was visited first, not the lowest index.
    const double limit2 = limit * limit * (1.0 + 1e-12);
    for (index_t k = m_cell_start[cell]; k < m_cell_start[cell + 1]; ++k) {
      const index_t i = m_cell_items[static_cast<std::size_t>(k)];
      if (box_squared_distance(i, p) > limit2) continue;
      const double d = distance(i);
      if (d <= max_distance && (d < best.distance || (d == best.distance && i < best.item)))
        best = {i, d};
    }
  };
  for (int r = 0;; ++r) {
    // The cells at Chebyshev distance exactly r from c, within the grid.
    const int z0 = std::max(0, c.z() - r), z1 = std::min(m_dims.z() - 1, c.z() + r);
    const int y0 = std::max(0, c.y() - r), y1 = std::min(m_dims.y() - 1, c.y() + r);
    for (int z = z0; z <= z1; ++z)
      for (int y = y0; y <= y1; ++y) {
        if (std::abs(z - c.z()) == r || std::abs(y - c.y()) == r) {
          for (int x = std::max(0, c.x() - r); x <= std::min(m_dims.x() - 1, c.x() + r); ++x)
            visit_cell(x, y, z);
        } else {
          if (c.x() - r >= 0) visit_cell(c.x() - r, y, z);
          if (r > 0 && c.x() + r < m_dims.x()) visit_cell(c.x() + r, y, z);
        }
      }
    // Everything unsearched lies beyond a face of the cube of cells [c − r, c + r] that is not
    // on the grid's boundary; its distance is at least p's distance to the nearest such face.
    double bound = std::numeric_limits<double>::infinity();
    for (int a = 0; a < 3; ++a) {
      if (c(a) - r > 0) bound = std::min(bound, p(a) - (m_origin(a) + (c(a) - r) * m_cell));
      if (c(a) + r < m_dims(a) - 1)
        bound = std::min(bound, m_origin(a) + (c(a) + r + 1) * m_cell - p(a));
    }
    if (bound == std::numeric_limits<double>::infinity()) break;  // the whole grid is searched
    bound = std::max(bound, 0.0) - slack;
    if (bound > best.distance || bound > max_distance) break;
  }
  if (best.item < 0) return std::nullopt;
  return best;
}

}  // namespace brainshift::core
