#include "constraints/registration/start/bulk_search.hpp"

#include "constraints/registration/start/distance_grid.hpp"
#include "constraints/registration/start/global_start.hpp"
#include "core/error.hpp"
#include "core/logger.hpp"
#include "core/mapping/closest_point.hpp"
#include "core/parallel.hpp"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <sstream>
#include <utility>
#include <vector>

namespace brainshift::constraints {

namespace detail {

MatrixX3d transformed(const Eigen::Isometry3d& T, ConstRef<MatrixX3d> p) {
  MatrixX3d out(p.rows(), 3);
  for (Eigen::Index i = 0; i < p.rows(); ++i)
    out.row(i) = (T * Vector3d(p.row(i).transpose())).transpose();
  return out;
}

/// The segments of `s` with both ends within the bounding box of `points` enlarged by `margin`
/// (mm): the part of the pre-operative tree the probe can have seen. A search against the
/// whole tree slides onto vessels outside the field of view (a dense cortical tree offers a
/// near-match every few millimetres).
core::Skeleton skeleton_near(const core::Skeleton& s, ConstRef<MatrixX3d> points, double margin) {
  if (points.rows() == 0) return s;
  const Vector3d lo = points.colwise().minCoeff().transpose().array() - margin;
  const Vector3d hi = points.colwise().maxCoeff().transpose().array() + margin;
  auto inside = [&](index_t i) {
    const Vector3d p = s.points.row(i).transpose();
    return (p.array() >= lo.array()).all() && (p.array() <= hi.array()).all();
  };
  core::Skeleton out = s;
  out.segments.clear();
  for (const auto& seg : s.segments)
    if (inside(seg[0]) && inside(seg[1])) out.segments.push_back(seg);
  return out.segments.empty() ? s : out;
}

namespace {

/// Point i moved back by the shift s: p_i − B_i s (B_i = I without a basis). One expression for
/// the coarse and the fine scores.
Vector3d moved_point(ConstRef<MatrixX3d> points, const std::vector<Matrix3d>& basis, Eigen::Index i,
                     const Vector3d& s) {
  return points.row(i).transpose() -
         (basis.empty() ? s : Vector3d(basis[static_cast<std::size_t>(i)] * s));
}

/// Offset of shift (x, y, z) (grid indices 0 … side − 1, x fastest) in the coarse scores.
std::size_t shift_offset(int side, int x, int y, int z) {
  return static_cast<std::size_t>(x) + static_cast<std::size_t>(side) * (y + side * z);
}

}  // namespace

std::vector<double> coarse_shift_scores(const DistanceGrid& table, ConstRef<MatrixX3d> points,
                                        const std::vector<Matrix3d>& basis, Eigen::Index stride,
                                        int k, double step, double tau) {
  BS_VERIFY(stride >= 1 && k >= 0 && step > 0 && tau > 0,
            "coarse shift scores: stride " << stride << " and k " << k << " (≥ 1, ≥ 0), step "
                                           << step << " mm and τ " << tau << " mm (> 0)");
  BS_VERIFY(basis.empty() || static_cast<Eigen::Index>(basis.size()) == points.rows(),
            "coarse shift scores: " << basis.size() << " basis matrices for " << points.rows()
                                    << " points");
  const Eigen::Index n = (points.rows() + stride - 1) / stride;
  const int side = 2 * k + 1;
  std::vector<double> scores(static_cast<std::size_t>(side) * side * side, 0.0);
  // Each plane writes its own scores: the same answer on any number of threads. Point by point
  // within a plane, one point's moves stay in a few cache lines of the table. At most 4 threads:
  // on the 2-core targets both, idle while the registration runs (the model load and the
  // extraction are over).
  core::parallel_chunks(
      static_cast<std::size_t>(side), core::hardware_threads(4), [&](std::size_t c) {
        const int z = static_cast<int>(c);
        for (Eigen::Index j = 0; j < n; ++j) {
          const Eigen::Index i = j * stride;
          for (int y = 0; y < side; ++y)
            for (int x = 0; x < side; ++x) {
              const Vector3d s = step * Vector3d(x - k, y - k, z - k);
              if (double d2 = 0; table.nearest_within_tau(moved_point(points, basis, i, s), d2))
                scores[shift_offset(side, x, y, z)] += std::max(0.0, 1.0 - d2 / (tau * tau));
            }
        }
      });
  return scores;
}

}  // namespace detail

std::string BulkSearchOptions::validate() const {
  if (!(radius_mm >= 0)) return "shift search: radius_mm must be ≥ 0";
  if (!(coarse_step_mm > 0)) return "shift search: coarse_step_mm must be > 0";
  if (!(fine_kernel_mm > 0) || !(coarse_kernel_mm >= fine_kernel_mm))
    return "shift search: kernels must satisfy 0 < fine_kernel_mm ≤ coarse_kernel_mm";
  if (!(voxel_mm > 0)) return "shift search: voxel_mm must be > 0";
  if (!(min_gain >= 1)) return "shift search: min_gain must be ≥ 1";
  if (max_points < 1) return "shift search: max_points must be ≥ 1";
  return {};
}

StartResult search_bulk_shift(const core::Skeleton& skeleton, ConstRef<MatrixX3d> points,
                              const std::vector<Matrix3d>& basis,
                              const BulkSearchOptions& options) {
  const std::string invalid = options.validate();
  BS_VERIFY(invalid.empty(), invalid);
  BS_VERIFY(points.allFinite() && skeleton.points.allFinite(),
            "shift search: inputs contain NaN or infinity");
  BS_VERIFY(
      basis.empty() || static_cast<Eigen::Index>(basis.size()) == points.rows(),
      "shift search: " << basis.size() << " basis matrices for " << points.rows() << " points");
  StartResult res;
  if (points.rows() == 0 || skeleton.segments.empty()) {
    res.bulk_message = "no points or no skeleton";
    return res;
  }
  const double R = options.radius_mm, tc = options.coarse_kernel_mm, tf = options.fine_kernel_mm;
  double reach = 1.0;  // largest ‖basisᵢ‖: how far a point can move for |s| ≤ R√3
  for (const Matrix3d& b : basis) reach = std::max(reach, b.operatorNorm());
  const double margin = reach * R * std::sqrt(3.0) + tc + options.voxel_mm;
  const Vector3d lo = points.colwise().minCoeff().transpose().array() - margin;
  const Vector3d hi = points.colwise().maxCoeff().transpose().array() + margin;
  const detail::DistanceGrid table(skeleton, lo, hi, options.voxel_mm, tc,
                                   /*stored_near_skeleton=*/true);
  const Eigen::Index stride = (points.rows() + options.max_points - 1) / options.max_points;
  const Eigen::Index n = (points.rows() + stride - 1) / stride;

  auto fine = [&](const Vector3d& s) {
    double score = 0;
    for (Eigen::Index j = 0; j < n; ++j) {
      const Vector3d q = detail::moved_point(points, basis, j * stride, s);
      score += std::max(0.0, 1.0 - table.trilinear(q) / (tf * tf));
    }
    return score;
  };

  // Coarse: every shift of the grid scored (coarse_shift_scores(): 95 % of the moved points on
  // ICBM152's sweep land beyond τ and are skipped on a bit), then scanned in order.
  const int k = static_cast<int>(std::floor(R / options.coarse_step_mm));
  const int side = 2 * k + 1;
  const std::vector<double> scores =
      detail::coarse_shift_scores(table, points, basis, stride, k, options.coarse_step_mm, tc);
  Vector3d best = Vector3d::Zero();
  double best_score = -1;
  for (int z = -k; z <= k; ++z)
    for (int y = -k; y <= k; ++y)
      for (int x = -k; x <= k; ++x) {
        const Vector3d s = options.coarse_step_mm * Vector3d(x, y, z);
        // Ties go to the smaller shift.
        const double sc = scores[detail::shift_offset(side, x + k, y + k, z + k)];
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
  res.score_identity = fine(Vector3d::Zero());
  // An optimum on the edge of the searched box is no peak: the score still grows outwards
  // (clutter, a vessel-free region next to the field of view), not a shift that was found.
  const bool on_edge = (centre.cwiseAbs().array() >= k * options.coarse_step_mm - 1e-9).any();
  res.bulk_accepted = fine_best > options.min_gain * res.score_identity && !on_edge;
  std::ostringstream os;
  os << "shift (" << best.x() << ", " << best.y() << ", " << best.z() << ") mm, score " << fine_best
     << " vs " << res.score_identity << " at zero over " << n << " points";
  if (res.bulk_accepted)
    res.bulk_shift = best;
  else if (on_edge)
    os << "; not accepted (optimum on the edge of the searched ±" << R << " mm)";
  else
    os << "; not accepted (gain below " << options.min_gain << ")";
  res.bulk_message = os.str();
  return res;
}

StartResult start_at_pose(const core::Skeleton& skeleton, ConstRef<MatrixX3d> points,
                          const Eigen::Isometry3d& pose, const BasisAt& basis_at,
                          const GlobalStartOptions& options, bool search, std::string reason) {
  StartResult res;
  if (search && options.bulk_search.enabled) {
    const BulkSearchOptions& so = options.bulk_search;
    const MatrixX3d placed = detail::transformed(pose, points);
    const std::vector<Matrix3d> basis = basis_at ? basis_at(placed) : std::vector<Matrix3d>{};
    res =
        search_bulk_shift(detail::skeleton_near(skeleton, placed, so.radius_mm), placed, basis, so);
    logger().debug("shift search: {}", res.bulk_message);
  }
  res.transform = pose;
  res.converged = true;
  res.stop_reason = std::move(reason);
  return res;
}

}  // namespace brainshift::constraints
