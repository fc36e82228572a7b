#include "constraints/registration/start/global_start.hpp"

#include "constraints/registration/start/distance_grid.hpp"
#include "constraints/registration/start/global_start_costs.hpp"
#include "constraints/registration/start/nearest_node.hpp"
#include "core/error.hpp"
#include "core/logger.hpp"
#include "core/mapping/closest_point.hpp"
#include "core/mesh/tet_mesh.hpp"
#include "core/timing.hpp"

#include <Eigen/Eigenvalues>
#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <numbers>
#include <sstream>
#include <utility>
#include <vector>

namespace brainshift::constraints {

namespace {

using core::Clock;
using core::seconds_since;
using detail::LineResidual;
using detail::Prior;
using detail::PriorWeights;
constexpr double kDeg = std::numbers::pi / 180.0;
constexpr double kMaxVoxels = 4.0e6;
/// A pose farther than this many standard deviations of the navigation prior is reported.
constexpr double kBeyondPriorZ = 3.0;

Matrix3d rotation(const Vector3d& w) {
  const double a = w.norm();
  return a > 0 ? Eigen::AngleAxisd(a, w / a).toRotationMatrix() : Matrix3d::Identity();
}

/// A pose: rotation vector w (rad) about the centroid, translation t (mm), bulk shift s (mm).
struct Pose {
  Vector3d w = Vector3d::Zero(), t = Vector3d::Zero(), s = Vector3d::Zero();
  double score = 0.0;
};

/// Points relative to the centroid, an even subsample of at most `count`.
MatrixX3d subsample(ConstRef<MatrixX3d> pc, int count) {
  const Eigen::Index stride = (pc.rows() + count - 1) / count;
  MatrixX3d out((pc.rows() + stride - 1) / stride, 3);
  for (Eigen::Index i = 0; i < out.rows(); ++i) out.row(i) = pc.row(i * stride);
  return out;
}

/// Everything one call shares: the centred points, the table, the bulk basis of the fine points.
struct Search {
  const core::Skeleton& skeleton;
  const GlobalStartOptions& o;
  Vector3d c;
  MatrixX3d coarse, fine;       // points − c
  std::vector<Matrix3d> basis;  // per fine point, or empty
  const detail::DistanceGrid* grid = nullptr;
  /// The bulk shift is refined in the frame [n e1 e2] (basis columns rotated to it), its first
  /// component (along the outward direction n) bounded above by 0: the brain sinks.
  bool sinks = false;

  [[nodiscard]] Vector3d place(const Matrix3d& R, const Pose& p, Eigen::Index i) const {
    Vector3d x = R * fine.row(i).transpose() + c + p.t;
    if (!basis.empty()) x -= basis[static_cast<std::size_t>(i)] * p.s;
    return x;
  }
  /// Fine score Σ κ_τf(d) over the fine points.
  [[nodiscard]] double score(const Pose& p) const {
    const Matrix3d R = rotation(p.w);
    const double tf2 = o.fine_kernel_mm * o.fine_kernel_mm;
    double s = 0;
    for (Eigen::Index i = 0; i < fine.rows(); ++i)
      s += std::max(0.0, 1.0 - grid->trilinear(place(R, p, i)) / tf2);
    return s;
  }
  /// Each fine point's share of score(p).
  [[nodiscard]] Eigen::VectorXd contributions(const Pose& p) const {
    const Matrix3d R = rotation(p.w);
    const double tf2 = o.fine_kernel_mm * o.fine_kernel_mm;
    Eigen::VectorXd share(fine.rows());
    for (Eigen::Index i = 0; i < fine.rows(); ++i)
      share(i) = std::max(0.0, 1.0 - grid->trilinear(place(R, p, i)) / tf2);
    return share;
  }
  /// RMS distance of the fine points within the coarse kernel, 0 when none.
  [[nodiscard]] double rms(const Pose& p) const {
    const Matrix3d R = rotation(p.w);
    const double tc2 = o.coarse_kernel_mm * o.coarse_kernel_mm;
    double s = 0;
    int n = 0;
    for (Eigen::Index i = 0; i < fine.rows(); ++i)
      if (const double d2 = grid->trilinear(place(R, p, i)); d2 < tc2 * 0.999) {
        s += d2;
        ++n;
      }
    return n ? std::sqrt(s / n) : 0.0;
  }
};

/// Coarse search: the best interior local maxima over the translation grid, each with its best
/// rotation of the grid. Ties go to the smaller motion (the identity rotation is tried first).
std::vector<Pose> coarse_search(const Search& S, const std::vector<Vector3d>& rotations,
                                double step, int sv, int K) {
  const detail::DistanceGrid& g = *S.grid;
  const int side = 2 * K + 1;
  const std::size_t nt = static_cast<std::size_t>(side) * side * side;
  std::vector<std::ptrdiff_t> off(nt);
  for (int z = -K, k = 0; z <= K; ++z)
    for (int y = -K; y <= K; ++y)
      for (int x = -K; x <= K; ++x, ++k)
        off[static_cast<std::size_t>(k)] =
            sv * (x + static_cast<std::ptrdiff_t>(g.dims().x()) *
                          (y + static_cast<std::ptrdiff_t>(g.dims().y()) * z));
  std::vector<std::uint32_t> best(nt, 0);
  std::vector<std::uint8_t> best_rot(nt, 0);
  std::vector<std::ptrdiff_t> base;
  base.reserve(static_cast<std::size_t>(S.coarse.rows()));
  const std::uint8_t* kern = g.kernel();
  for (std::size_t r = 0; r < rotations.size(); ++r) {
    const Matrix3d R = rotation(rotations[r]);
    base.clear();
    for (Eigen::Index i = 0; i < S.coarse.rows(); ++i) {
      const Eigen::Vector3i c = g.nearest_cell(R * S.coarse.row(i).transpose() + S.c);
      if (g.inside(c, K * sv))
        base.push_back(static_cast<std::ptrdiff_t>(g.index(c.x(), c.y(), c.z())));
    }
    for (std::size_t k = 0; k < nt; ++k) {
      const std::uint8_t* p = kern + off[k];
      std::uint32_t sum = 0;
      for (const std::ptrdiff_t b : base) sum += p[b];
      if (sum > best[k]) {
        best[k] = sum;
        best_rot[k] = static_cast<std::uint8_t>(r);
      }
    }
  }
  // Interior local maxima (plateaus broken by the scan order).
  std::vector<Pose> maxima;
  auto at = [&](int x, int y, int z) {
    return static_cast<std::size_t>((x + K) + side * ((y + K) + side * (z + K)));
  };
  for (int z = -K + 1; z < K; ++z)
    for (int y = -K + 1; y < K; ++y)
      for (int x = -K + 1; x < K; ++x) {
        const std::size_t k = at(x, y, z);
        if (best[k] == 0) continue;
        bool is_max = true;
        for (int dz = -1; dz <= 1 && is_max; ++dz)
          for (int dy = -1; dy <= 1 && is_max; ++dy)
            for (int dx = -1; dx <= 1 && is_max; ++dx) {
              const std::size_t n = at(x + dx, y + dy, z + dz);
              if (n != k && (best[n] > best[k] || (best[n] == best[k] && n < k))) is_max = false;
            }
        if (!is_max) continue;
        Pose p;
        p.w = rotations[best_rot[k]];
        p.t = step * Vector3d(x, y, z);
        p.score = best[k] / 255.0;
        maxima.push_back(p);
      }
  std::sort(maxima.begin(), maxima.end(), [](const Pose& a, const Pose& b) {
    return a.score != b.score ? a.score > b.score
                              : a.t.norm() + a.w.norm() < b.t.norm() + b.w.norm();
  });
  if (maxima.size() > static_cast<std::size_t>(S.o.candidates))
    maxima.resize(static_cast<std::size_t>(S.o.candidates));
  return maxima;
}

/// Local rescoring of a coarse candidate with the fine kernel, by coordinate ascent: the 27
/// translations within ± half the translation step, then the 7 rotations (± half the rotation
/// step about each axis) at the best, then the translations again.
Pose rescore(const Search& S, const Pose& c, double rot_step, double step) {
  Pose best = c;
  best.score = S.score(c);
  auto translations = [&] {
    const Pose centre = best;
    for (int z = -1; z <= 1; ++z)
      for (int y = -1; y <= 1; ++y)
        for (int x = -1; x <= 1; ++x) {
          if (x == 0 && y == 0 && z == 0) continue;
          Pose p = centre;
          p.t += 0.5 * step * Vector3d(x, y, z);
          if ((p.score = S.score(p)) > best.score) best = p;
        }
  };
  translations();
  const Pose centre = best;
  for (int r = 0; r < 6; ++r) {
    Pose p = centre;
    p.w[r / 2] += (r % 2 ? 0.5 : -0.5) * rot_step;
    if ((p.score = S.score(p)) > best.score) best = p;
  }
  translations();
  return best;
}

/// Robust ICP from `start` (Ceres, Cauchy loss); returns the refined pose (score not set).
Pose refine(const Search& S, Pose p, bool bulk, int& rounds, index_t& pairs) {
  const GlobalStartOptions& o = S.o;
  const double radius = std::max(1.0, std::sqrt(S.fine.rowwise().squaredNorm().mean()));
  rounds = 0;
  for (int it = 1; it <= o.refine_iterations; ++it) {
    const Matrix3d R = rotation(p.w);
    ceres::CauchyLoss loss(o.loss_scale_mm);  // outlives the problem, which does not own it
    ceres::Problem::Options po;
    po.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    ceres::Problem problem(po);
    index_t n = 0;
    for (Eigen::Index i = 0; i < S.fine.rows(); ++i) {
      const Vector3d x = S.place(R, p, i);
      const std::int32_t seg = S.grid->segment(x);
      if (seg < 0) continue;
      const auto& e = S.skeleton.segments[static_cast<std::size_t>(seg)];
      const Vector3d a = S.skeleton.points.row(e[0]).transpose(),
                     b = S.skeleton.points.row(e[1]).transpose();
      const Vector3d q = a + core::closest_point_on_segment(x, a, b) * (b - a);
      if ((x - q).norm() > o.refine_distance_mm) continue;
      const double len = (b - a).norm();
      const Vector3d d = len > 0 ? Vector3d((b - a) / len) : Vector3d::Zero();
      auto* cf = new ceres::AutoDiffCostFunction<LineResidual, 3, 3, 3, 3>(new LineResidual{
          S.fine.row(i).transpose(), S.c - q, Matrix3d::Identity() - d * d.transpose(),
          S.basis.empty() ? Matrix3d::Zero() : S.basis[static_cast<std::size_t>(i)]});
      problem.AddResidualBlock(cf, &loss, p.w.data(), p.t.data(), p.s.data());
      ++n;
    }
    if (n < 3) break;  // too few pairs to refine: keep the searched pose
    pairs = n;
    const PriorWeights k(o);
    if (k.t > 0) {
      problem.AddResidualBlock(new ceres::AutoDiffCostFunction<Prior, 3, 3>(new Prior{k.t}),
                               nullptr, p.t.data());
      problem.AddResidualBlock(new ceres::AutoDiffCostFunction<Prior, 3, 3>(new Prior{k.w}),
                               nullptr, p.w.data());
    }
    if (bulk && !S.basis.empty())
      problem.AddResidualBlock(
          new ceres::AutoDiffCostFunction<Prior, 3, 3>(new Prior{
              k.map ? k.s : std::sqrt(static_cast<double>(n)) * o.loss_scale_mm / o.bulk_prior_mm}),
          nullptr, p.s.data());
    else
      problem.SetParameterBlockConstant(p.s.data());
    if (bulk && !S.basis.empty() && S.sinks) problem.SetParameterUpperBound(p.s.data(), 0, 0.0);
    const Pose old = p;
    ceres::Solver::Options so;
    so.linear_solver_type = ceres::DENSE_QR;
    so.max_num_iterations = o.solver_iterations;
    so.logging_type = ceres::SILENT;
    so.num_threads = 1;
    ceres::Solver::Summary summary;
    ceres::Solve(so, &problem, &summary);
    rounds = it;
    if (!summary.IsSolutionUsable() || !p.w.allFinite() || !p.t.allFinite() || !p.s.allFinite())
      return old;
    const double change = (p.t - old.t).norm() + (p.s - old.s).norm() +
                          Eigen::AngleAxisd(rotation(p.w) * R.transpose()).angle() * radius;
    if (change < o.convergence_mm) break;
  }
  return p;
}

std::string fmt(const Vector3d& v, int precision = 2) {
  std::ostringstream os;
  os.setf(std::ios::fixed);
  os.precision(precision);
  os << "(" << v.x() << ", " << v.y() << ", " << v.z() << ")";
  return os.str();
}

/// The kernel-correlation table's grid: voxel size h, the coarse step (sv voxels, `step` mm),
/// the translation count K per side and the box [lo, hi]: the points' box grown by every
/// translation and rotation the coarse grid tries, the voxel grown until it fits kMaxVoxels.
struct TableGrid {
  double h = 0, step = 0;
  int sv = 1, K = 0;
  Vector3d lo, hi;
};

TableGrid table_grid(ConstRef<MatrixX3d> points, double r_max, double rot_step,
                     const GlobalStartOptions& o) {
  TableGrid g;
  double& h = g.h;
  int &sv = g.sv, &K = g.K;
  double& step = g.step;
  Vector3d &lo = g.lo, &hi = g.hi;
  h = o.voxel_mm;
  for (int attempt = 0; attempt < 8; ++attempt) {
    sv = std::max(1, static_cast<int>(std::lround(o.coarse_step_mm / h)));
    step = sv * h;
    K = static_cast<int>(std::ceil(o.max_translation_mm / step - 1e-9)) + 1;
    const double margin = K * step + r_max * std::sqrt(3.0) * rot_step + o.coarse_kernel_mm + 3 * h;
    lo = points.colwise().minCoeff().transpose().array() - margin;
    hi = points.colwise().maxCoeff().transpose().array() + margin;
    const double voxels = ((hi - lo) / h).array().ceil().prod();
    if (voxels <= kMaxVoxels) break;
    h *= std::cbrt(voxels / kMaxVoxels) * 1.01;
  }
  return g;
}

/// The best candidate distinct from the top one (the candidates sorted by fine score), and the
/// points' spread along their principal axes.
void runner_up_and_spread(const Search& S, const std::vector<Pose>& cands,
                          const GlobalStartOptions& o, StartResult& res) {
  // The best candidate distinct from the top one (the candidates are sorted by fine score).
  if (!cands.empty() && cands.front().score > 0) {
    auto placed = [&S](const Pose& p) -> MatrixX3d {
      return (S.fine * rotation(p.w).transpose()).rowwise() + p.t.transpose();
    };
    const MatrixX3d top = placed(cands.front());
    for (std::size_t k = 1; k < cands.size(); ++k) {
      const double d = std::sqrt((placed(cands[k]) - top).rowwise().squaredNorm().mean());
      if (d >= o.ambiguity_distance_mm) {
        res.runner_up_ratio = cands[k].score / cands.front().score;
        res.runner_up_distance_mm = d;
        break;
      }
    }
  }
  {
    const Matrix3d cov = S.fine.transpose() * S.fine / static_cast<double>(S.fine.rows());
    const Eigen::SelfAdjointEigenSolver<Matrix3d> es(cov);
    const Vector3d ev = es.eigenvalues().cwiseMax(0.0).cwiseSqrt();
    res.spread_mm = Vector3d(ev(2), ev(1), ev(0));
  }
}

/// Step 3: the refinement of the best candidate and of any within 10 % of it (rigid, then the
/// bulk shift jointly in the frame Q where it sinks), compared by the posterior; the identity
/// when nothing beats it.
Pose refine_best(Search& S, const std::vector<Pose>& cands, const Pose& identity,
                 const BasisAt& basis_at, const GlobalStartOptions& o, const Vector3d& outward,
                 StartResult& res, Matrix3d& Q) {
  Pose best = identity;
  best.score = res.score_identity;
  Q = Matrix3d::Identity();
  if (!cands.empty()) {
    const bool bulk = o.bulk_response && basis_at;
    if (bulk) {
      const Matrix3d R = rotation(cands.front().w);
      const MatrixX3d placed =
          (S.fine * R.transpose()).rowwise() + (S.c + cands.front().t).transpose();
      S.basis = basis_at(placed);
      if (static_cast<Eigen::Index>(S.basis.size()) != S.fine.rows()) S.basis.clear();
      // The brain sinks: s is refined as Q σ with Q = [n e1 e2] orthonormal, n outward, and
      // σ₀ = n·s ≤ 0 (a bound of the trust-region solver); the basis columns are rotated to Q.
      if (o.bulk_sinks && outward.norm() > 0 && !S.basis.empty()) {
        const Vector3d n = outward.normalized();
        const Vector3d a = std::abs(n.x()) < 0.9 ? Vector3d::UnitX() : Vector3d::UnitY();
        const Vector3d e1 = n.cross(a).normalized();
        Q << n, e1, n.cross(e1);
        for (Matrix3d& b : S.basis) b = b * Q;
        S.sinks = true;
      }
    }
    // Candidates compete by the posterior: the fine score less the priors' cost.
    const PriorWeights kw(o);
    const auto posterior = [&](const Pose& q) {
      return q.score - kw.penalty(q.t, q.w, q.s, o.fine_kernel_mm);
    };
    const double top = cands.front().score;
    for (std::size_t k = 0; k < cands.size() && k < 3 && cands[k].score >= 0.9 * top; ++k) {
      // Rigid first; then the bulk shift jointly, kept only when it is large enough to report
      // (a small s would otherwise bias the rigid part it is traded against).
      int rounds = 0;
      index_t pairs = 0;
      Pose p = refine(S, cands[k], false, rounds, pairs);
      if (bulk && !S.basis.empty()) {
        int more = 0;
        index_t joint_pairs = 0;
        if (const Pose q = refine(S, p, true, more, joint_pairs); q.s.norm() >= o.bulk_min_mm) {
          p = q;
          rounds += more;
          pairs = joint_pairs;
        }
      }
      p.score = S.score(p);
      if (posterior(p) < posterior(cands[k]))
        p = cands[k];  // the refinement lost: keep the searched pose
      if (posterior(p) > posterior(best)) {
        best = p;
        res.refine_iterations = rounds;
        res.pairs = pairs;
      }
    }
  }
  return best;
}

/// The gain must stand out of its own scatter: the points grouped in blocks of
/// significance_block_mm (errors along a vessel are correlated within a block, not across), the
/// blocks' mean gain over its standard error ≥ significance_z. Fewer than 4 blocks: not tested.
void test_significance(const Search& S, const Pose& best, const Pose& identity,
                       const GlobalStartOptions& o, StartResult& res) {
  const Eigen::VectorXd g = S.contributions(best) - S.contributions(identity);
  std::map<std::array<long, 3>, double> blocks;
  for (Eigen::Index i = 0; i < S.fine.rows(); ++i) {
    const Vector3d q = S.fine.row(i).transpose() / o.significance_block_mm;
    blocks[{long(std::floor(q(0))), long(std::floor(q(1))), long(std::floor(q(2)))}] += g(i);
  }
  res.gain_blocks = static_cast<int>(blocks.size());
  if (blocks.size() >= 4) {
    double sum = 0, sum2 = 0;
    for (const auto& [key, b] : blocks) {
      sum += b;
      sum2 += b * b;
    }
    const double n = double(blocks.size());
    const double mean = sum / n;
    const double sd = std::sqrt(std::max(0.0, (sum2 - n * mean * mean) / (n - 1)));
    res.gain_z = sd > 0 ? mean / (sd / std::sqrt(n)) : std::numeric_limits<double>::infinity();
    if (res.gain_z < o.significance_z) res.accepted = false;
  }
}

/// An accepted pose into the result and the message.
void accept_pose(const Search& S, Pose best, const Matrix3d& Q, const GlobalStartOptions& o,
                 StartResult& res, std::ostringstream& os) {
  const Matrix3d R = rotation(best.w);
  res.transform.linear() = R;
  res.transform.translation() = S.c + best.t - R * S.c;
  res.translation_mm = best.t.norm();
  res.rotation_deg = best.w.norm() / kDeg;
  if (const PriorWeights kw(o); kw.map)
    res.prior_z =
        std::sqrt(kw.t * kw.t * best.t.squaredNorm() + kw.w * kw.w * best.w.squaredNorm()) /
        o.loss_scale_mm;
  res.bulk_accepted = !S.basis.empty() && best.s.norm() >= o.bulk_min_mm;
  if (!res.bulk_accepted) best.s.setZero();
  res.score = S.score(best);  // with s in the frame the basis was rotated to
  res.rms_after_mm = S.rms(best);
  if (res.bulk_accepted) res.bulk_shift = Q * best.s;  // back to the model frame
  os << "rigid " << res.translation_mm << " mm at the centroid, " << res.rotation_deg
     << " deg; bulk shift ";
  if (res.bulk_accepted)
    os << fmt(res.bulk_shift) << " mm";
  else
    os << (S.basis.empty() ? "not searched"
                           : "below " + std::to_string(o.bulk_min_mm).substr(0, 4) + " mm");
  os << "; score " << res.score << " vs " << res.score_identity << " at the identity over "
     << res.points << " points";
  std::ostringstream why;
  why.setf(std::ios::fixed);
  why.precision(2);
  if (res.runner_up_ratio >= o.ambiguity_ratio)
    why << "a pose " << res.runner_up_distance_mm << " mm away scores "
        << 100.0 * res.runner_up_ratio << " % of the best";
  else if (res.spread_mm(1) < o.min_spread_mm)
    why << "the points spread " << res.spread_mm(1) << " mm across their main axis (below "
        << o.min_spread_mm << " mm): the rotation about it is not pinned";
  res.ambiguity = why.str();
  res.ambiguous = !res.ambiguity.empty();
  if (res.ambiguous) os << "; ambiguous: " << res.ambiguity;
  if (res.prior_z > kBeyondPriorZ)
    os << "; the pose is " << res.prior_z
       << " standard deviations of the navigation's stated accuracy from the identity: the data "
          "moved the fixed base beyond it";
}

/// The identity kept: the result and the message say why.
void keep_identity(const Pose& best, const GlobalStartOptions& o, StartResult& res,
                   std::ostringstream& os) {
  res.score = res.score_identity;
  res.rms_after_mm = res.rms_before_mm;
  os << "identity kept: the best pose scores " << best.score << " vs " << res.score_identity
     << " at the identity over " << res.points << " points (";
  if (best.score > o.min_gain * res.score_identity && best.score > 0)
    os << "gain " << res.gain_z << " standard errors over " << res.gain_blocks << " blocks of "
       << o.significance_block_mm << " mm, below " << o.significance_z << ")";
  else
    os << "gain below " << o.min_gain << ")";
}

/// The searched pose as the registration reports it: in use when accepted, the search's message
/// as the reason, and where the bulk shift came from.
StartResult with_reasons(StartResult res) {
  res.converged = res.accepted;
  res.stop_reason = "global start: " + res.message;
  res.bulk_message = res.bulk_accepted ? "from the global start" : "none from the global start";
  return res;
}

}  // namespace

StartResult global_start(const core::Skeleton& skeleton, ConstRef<MatrixX3d> points,
                         const BasisAt& basis_at, const GlobalStartOptions& o,
                         const Vector3d& outward) {
  const auto t0 = Clock::now();
  const std::string invalid = o.validate();
  BS_VERIFY(invalid.empty(), invalid);
  BS_VERIFY(points.allFinite() && skeleton.points.allFinite() && outward.allFinite(),
            "global start: inputs contain NaN or infinity");
  StartResult res;
  if (points.rows() < o.min_points || skeleton.segments.empty()) {
    res.message = skeleton.segments.empty()
                      ? "no skeleton segments: identity"
                      : std::to_string(points.rows()) + " vessel points, fewer than the " +
                            std::to_string(o.min_points) + " needed: identity";
    res.seconds = seconds_since(t0);
    return with_reasons(std::move(res));
  }
  Search S{skeleton, o, points.colwise().mean().transpose(), {}, {}, {}, nullptr};
  const MatrixX3d pc = points.rowwise() - S.c.transpose();
  S.coarse = subsample(pc, o.coarse_points);
  S.fine = subsample(pc, o.max_points);
  res.points = static_cast<int>(S.fine.rows());

  // The table: the points' box, grown by every translation and rotation the coarse grid tries.
  const double rot_step = o.max_rotation_deg * kDeg / 1.5;
  const double r_max = pc.rowwise().norm().maxCoeff();
  const TableGrid tg = table_grid(points, r_max, rot_step, o);
  const double h = tg.h, step = tg.step;
  const int sv = tg.sv, K = tg.K;
  const Vector3d lo = tg.lo, hi = tg.hi;
  const detail::DistanceGrid grid(skeleton, lo, hi, h, o.coarse_kernel_mm);
  S.grid = &grid;
  res.seconds_table = seconds_since(t0);

  // 1. Coarse: every translation × every rotation of the grid (identity first).
  auto t1 = Clock::now();
  std::vector<Vector3d> rotations{Vector3d::Zero()};
  if (rot_step > 0)
    for (int z = -1; z <= 1; ++z)
      for (int y = -1; y <= 1; ++y)
        for (int x = -1; x <= 1; ++x)
          if (x || y || z) rotations.push_back(rot_step * Vector3d(x, y, z));
  std::vector<Pose> cands = coarse_search(S, rotations, step, sv, K);
  res.candidates = static_cast<int>(cands.size());
  res.seconds_coarse = seconds_since(t1);

  // 2. Fine rescoring of the candidates.
  t1 = Clock::now();
  const Pose identity;
  res.score_identity = S.score(identity);
  for (Pose& c : cands) c = rescore(S, c, rot_step, step);
  std::sort(cands.begin(), cands.end(),
            [](const Pose& a, const Pose& b) { return a.score > b.score; });
  res.seconds_fine = seconds_since(t1);
  runner_up_and_spread(S, cands, o, res);

  // 3. Refinement of the best and of any within 10 % of it; the bulk basis where the best puts the
  // points.
  t1 = Clock::now();
  Matrix3d Q = Matrix3d::Identity();  // the frame the bulk shift is refined in
  Pose best = refine_best(S, cands, identity, basis_at, o, outward, res, Q);
  res.seconds_refine = seconds_since(t1);

  // 4. Decision by the data score.
  res.rms_before_mm = S.rms(identity);
  res.accepted = best.score > o.min_gain * res.score_identity && best.score > 0;
  if (res.accepted && o.significance_z > 0) test_significance(S, best, identity, o, res);
  std::ostringstream os;
  os.setf(std::ios::fixed);
  os.precision(2);
  if (res.accepted)
    accept_pose(S, best, Q, o, res, os);
  else
    keep_identity(best, o, res, os);
  os << " (" << res.candidates << " candidates, " << res.refine_iterations << " refinement rounds)";
  res.message = os.str();
  res.seconds = seconds_since(t0);
  logger().debug("global start: runner-up {:.3f} at {:.1f} mm, spread {:.1f} / {:.1f} / {:.1f} mm",
                 res.runner_up_ratio, res.runner_up_distance_mm, res.spread_mm(0), res.spread_mm(1),
                 res.spread_mm(2));
  logger().debug(
      "global start: {} in {:.1f} ms (table {:.1f}, coarse {:.1f}, fine {:.1f}, refine {:.1f})",
      res.message, 1e3 * res.seconds, 1e3 * res.seconds_table, 1e3 * res.seconds_coarse,
      1e3 * res.seconds_fine, 1e3 * res.seconds_refine);
  return with_reasons(std::move(res));
}

}  // namespace brainshift::constraints
