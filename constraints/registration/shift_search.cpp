#include "constraints/registration/shift_search.hpp"

#include "core/error.hpp"
#include "core/mapping/closest_point.hpp"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <sstream>
#include <vector>

namespace brainshift::constraints {

std::string ShiftSearchOptions::validate() const {
  if (!(radius_mm >= 0)) return "shift search: radius_mm must be ≥ 0";
  if (!(coarse_step_mm > 0)) return "shift search: coarse_step_mm must be > 0";
  if (!(fine_kernel_mm > 0) || !(coarse_kernel_mm >= fine_kernel_mm))
    return "shift search: kernels must satisfy 0 < fine_kernel_mm ≤ coarse_kernel_mm";
  if (!(voxel_mm > 0)) return "shift search: voxel_mm must be > 0";
  if (!(min_gain >= 1)) return "shift search: min_gain must be ≥ 1";
  if (max_points < 1) return "shift search: max_points must be ≥ 1";
  return {};
}

namespace {

/// Squared distance to the nearest segment, truncated at τ², tabulated on a voxel grid.
class DistanceTable {
 public:
  DistanceTable(const core::Skeleton& s, const Vector3d& lo, const Vector3d& hi, double h,
                double tau)
      : m_lo(lo), m_h(h), m_tau2(static_cast<float>(tau * tau)) {
    m_dims = (((hi - lo) / h).array().ceil().cast<int>() + 1).matrix();
    m_d2.assign(static_cast<std::size_t>(m_dims.prod()), m_tau2);
    m_seg.assign(m_d2.size(), -1);
    for (std::size_t si = 0; si < s.segments.size(); ++si) {
      const auto& seg = s.segments[si];
      const Vector3d a = s.points.row(seg[0]).transpose(), b = s.points.row(seg[1]).transpose();
      const Eigen::Vector3i c0 = cell(a.cwiseMin(b).array() - tau),
                            c1 = cell(a.cwiseMax(b).array() + tau);
      if ((c1.array() < 0).any() || (c0.array() >= m_dims.array()).any()) continue;
      const Eigen::Vector3i l = c0.cwiseMax(0), u = c1.cwiseMin(m_dims - Eigen::Vector3i::Ones());
      for (int z = l.z(); z <= u.z(); ++z)
        for (int y = l.y(); y <= u.y(); ++y)
          for (int x = l.x(); x <= u.x(); ++x) {
            const Vector3d q = m_lo + h * Vector3d(x, y, z);
            const double t = core::closest_point_on_segment(q, a, b);
            float& d = m_d2[index(x, y, z)];
            const auto e = static_cast<float>((q - (a + t * (b - a))).squaredNorm());
            if (e < d) {
              d = e;
              m_seg[index(x, y, z)] = static_cast<std::int32_t>(si);
            }
          }
    }
  }
  /// Nearest-voxel lookup (coarse search).
  [[nodiscard]] float nearest(const Vector3d& q) const {
    const Eigen::Vector3i c = ((q - m_lo) / m_h).array().round().cast<int>();
    if ((c.array() < 0).any() || (c.array() >= m_dims.array()).any()) return m_tau2;
    return m_d2[index(c.x(), c.y(), c.z())];
  }
  /// Segment nearest to the voxel nearest q, −1 beyond τ.
  [[nodiscard]] std::int32_t segment(const Vector3d& q) const {
    const Eigen::Vector3i c = ((q - m_lo) / m_h).array().round().cast<int>();
    if ((c.array() < 0).any() || (c.array() >= m_dims.array()).any()) return -1;
    return m_seg[index(c.x(), c.y(), c.z())];
  }
  /// Trilinear lookup (refinement).
  [[nodiscard]] double trilinear(const Vector3d& q) const {
    const Vector3d g = (q - m_lo) / m_h;
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
  [[nodiscard]] Eigen::Vector3i cell(const Vector3d& p) const {
    return ((p - m_lo) / m_h).array().floor().cast<int>();
  }
  [[nodiscard]] std::size_t index(int x, int y, int z) const {
    return x +
           static_cast<std::size_t>(m_dims.x()) * (y + static_cast<std::size_t>(m_dims.y()) * z);
  }
  Vector3d m_lo;
  double m_h;
  float m_tau2;
  Eigen::Vector3i m_dims;
  std::vector<float> m_d2;
  std::vector<std::int32_t> m_seg;
};

}  // namespace

ShiftSearchResult search_shift(const core::Skeleton& skeleton, ConstRef<MatrixX3d> points,
                               const std::vector<Matrix3d>& basis,
                               const ShiftSearchOptions& options) {
  const std::string invalid = options.validate();
  BS_VERIFY(invalid.empty(), invalid);
  BS_VERIFY(points.allFinite() && skeleton.points.allFinite(),
            "shift search: inputs contain NaN or infinity");
  BS_VERIFY(
      basis.empty() || static_cast<Eigen::Index>(basis.size()) == points.rows(),
      "shift search: " << basis.size() << " basis matrices for " << points.rows() << " points");
  ShiftSearchResult res;
  if (points.rows() == 0 || skeleton.segments.empty()) {
    res.message = "no points or no skeleton";
    return res;
  }
  const double R = options.radius_mm, tc = options.coarse_kernel_mm, tf = options.fine_kernel_mm;
  double reach = 1.0;  // largest ‖basisᵢ‖: how far a point can move for |s| ≤ R√3
  for (const Matrix3d& b : basis) reach = std::max(reach, b.operatorNorm());
  const double margin = reach * R * std::sqrt(3.0) + tc + options.voxel_mm;
  const Vector3d lo = points.colwise().minCoeff().transpose().array() - margin;
  const Vector3d hi = points.colwise().maxCoeff().transpose().array() + margin;
  const DistanceTable table(skeleton, lo, hi, options.voxel_mm, tc);
  const Eigen::Index stride = (points.rows() + options.max_points - 1) / options.max_points;
  const Eigen::Index n = (points.rows() + stride - 1) / stride;

  auto moved = [&](Eigen::Index j, const Vector3d& s) -> Vector3d {
    const Eigen::Index i = j * stride;
    return points.row(i).transpose() -
           (basis.empty() ? s : Vector3d(basis[static_cast<std::size_t>(i)] * s));
  };
  auto coarse = [&](const Vector3d& s) {
    double score = 0;
    for (Eigen::Index i = 0; i < n; ++i) {
      const Vector3d q = moved(i, s);
      score += std::max(0.0, 1.0 - table.nearest(q) / (tc * tc));
    }
    return score;
  };
  auto fine = [&](const Vector3d& s) {
    double score = 0;
    for (Eigen::Index i = 0; i < n; ++i) {
      const Vector3d q = moved(i, s);
      score += std::max(0.0, 1.0 - table.trilinear(q) / (tf * tf));
    }
    return score;
  };

  // Coarse: every shift of the grid.
  const int k = static_cast<int>(std::floor(R / options.coarse_step_mm));
  Vector3d best = Vector3d::Zero();
  double best_score = -1;
  for (int z = -k; z <= k; ++z)
    for (int y = -k; y <= k; ++y)
      for (int x = -k; x <= k; ++x) {
        const Vector3d s = options.coarse_step_mm * Vector3d(x, y, z);
        // Ties go to the smaller shift.
        const double sc = coarse(s);
        if (sc > best_score + 1e-9 || (sc > best_score - 1e-9 && s.norm() < best.norm())) {
          best_score = sc;
          best = s;
        }
      }
  // Fine: a quarter-step grid around the coarse optimum, with the narrower kernel.
  const Vector3d centre = best;
  double fine_best = fine(centre);
  const double h = options.coarse_step_mm / 4;
  for (int z = -4; z <= 4; ++z)
    for (int y = -4; y <= 4; ++y)
      for (int x = -4; x <= 4; ++x) {
        const Vector3d s = centre + h * Vector3d(x, y, z);
        if (const double sc = fine(s); sc > fine_best) {
          fine_best = sc;
          best = s;
        }
      }
  res.score = fine_best;
  res.score_zero = fine(Vector3d::Zero());
  // An optimum on the edge of the searched box is no peak: the score still grows outwards
  // (clutter, a vessel-free region next to the field of view), not a shift that was found.
  const bool on_edge = (centre.cwiseAbs().array() >= k * options.coarse_step_mm - 1e-9).any();
  res.accepted = fine_best > options.min_gain * res.score_zero && !on_edge;
  std::ostringstream os;
  os << "shift (" << best.x() << ", " << best.y() << ", " << best.z() << ") mm, score " << fine_best
     << " vs " << res.score_zero << " at zero over " << n << " points";
  if (res.accepted)
    res.shift = best;
  else if (on_edge)
    os << "; not accepted (optimum on the edge of the searched ±" << R << " mm)";
  else
    os << "; not accepted (gain below " << options.min_gain << ")";
  res.message = os.str();
  return res;
}

}  // namespace brainshift::constraints
