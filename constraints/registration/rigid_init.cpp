#include "constraints/registration/rigid_init.hpp"

#include "constraints/registration/pairing.hpp"
#include "core/error.hpp"
#include "core/logger.hpp"

#include <Eigen/Eigenvalues>
#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <sstream>
#include <vector>

namespace brainshift::constraints {

std::string RigidInitOptions::validate() const {
  std::ostringstream os;
  if (!(loss_scale_mm > 0.0) || !std::isfinite(loss_scale_mm))
    os << "loss_scale_mm is " << loss_scale_mm << ", expected a finite value > 0 (mm); ";
  if (max_icp_iterations < 1)
    os << "max_icp_iterations is " << max_icp_iterations << ", expected ≥ 1; ";
  if (!(max_pair_distance_mm > 0.0))
    os << "max_pair_distance_mm is " << max_pair_distance_mm << ", expected > 0 (mm); ";
  if (!(footprint_weight >= 0.0) || !std::isfinite(footprint_weight))
    os << "footprint_weight is " << footprint_weight << ", expected a finite value ≥ 0; ";
  if (!(convergence_mm > 0.0) || !std::isfinite(convergence_mm))
    os << "convergence_mm is " << convergence_mm << ", expected a finite value > 0 (mm); ";
  if (max_solver_iterations < 1)
    os << "max_solver_iterations is " << max_solver_iterations << ", expected ≥ 1; ";
  if (!(weak_dof_ratio > 0.0 && weak_dof_ratio < 1.0))
    os << "weak_dof_ratio is " << weak_dof_ratio << ", expected in (0, 1); ";
  return os.str();
}

namespace {

/// A pair: point (intra-operative, untransformed), closest feature point q, projector P
/// (I − t tᵀ for a segment, n nᵀ for a triangle) and its current distance.
struct RigidPair {
  Vector3d p;
  Vector3d q;
  Matrix3d projector;
  Vector3d normal;  ///< triangle normal (plane pairs only)
  bool plane = false;
  double distance = 0.0;  ///< Euclidean distance to q at pairing time, mm
};

/// Residual (I − t tᵀ)(R(p − c) + c + t − q), 3 components (rank 2), with p − c and q − c stored.
struct LineResidual {
  Vector3d pc, qc;
  Matrix3d P;
  template <typename T>
  bool operator()(const T* w, const T* t, T* r) const {
    const T p[3] = {T(pc.x()), T(pc.y()), T(pc.z())};
    T rp[3];
    ceres::AngleAxisRotatePoint(w, p, rp);
    T d[3];
    for (int i = 0; i < 3; ++i) d[i] = rp[i] + t[i] - T(qc[i]);
    for (int i = 0; i < 3; ++i) r[i] = T(P(i, 0)) * d[0] + T(P(i, 1)) * d[1] + T(P(i, 2)) * d[2];
    return true;
  }
};

/// Residual n·(R(p − c) + c + t − q).
struct PlaneResidual {
  Vector3d pc, qc, n;
  template <typename T>
  bool operator()(const T* w, const T* t, T* r) const {
    const T p[3] = {T(pc.x()), T(pc.y()), T(pc.z())};
    T rp[3];
    ceres::AngleAxisRotatePoint(w, p, rp);
    r[0] = T(0);
    for (int i = 0; i < 3; ++i) r[0] += T(n[i]) * (rp[i] + t[i] - T(qc[i]));
    return true;
  }
};

Matrix3d rotation_of(const Vector3d& w) {
  Matrix3d R;
  ceres::AngleAxisToRotationMatrix(w.data(), ceres::ColumnMajorAdapter3x3(R.data()));
  return R;
}

/// Pairs every point of `pts` (mapped by x ↦ R(x − c) + c + t) with its closest feature of
/// `index` (segments when !plane, triangles when plane) within max_dist.
void pair_points(const FeatureIndex& index, const core::Skeleton& skel, ConstRef<MatrixX3d> pts,
                 bool plane, const Matrix3d& R, const Vector3d& c, const Vector3d& t,
                 double max_dist, std::vector<RigidPair>& out) {
  if (pts.rows() == 0 || index.size() == 0) return;
  const MatrixX3d x =
      ((pts.rowwise() - c.transpose()) * R.transpose()).rowwise() + (c + t).transpose();
  for (const Pair& pr : index.pair(x, max_dist)) {
    RigidPair rp;
    rp.p = pts.row(pr.point).transpose();
    rp.q = pr.closest;
    rp.distance = pr.distance;
    rp.plane = plane;
    if (plane) {
      rp.normal = pr.direction;
      rp.projector = rp.normal * rp.normal.transpose();
    } else {
      const auto& e = skel.segments[static_cast<std::size_t>(pr.feature)];
      const bool point_like = skel.points.row(e[0]) == skel.points.row(e[1]);
      rp.normal.setZero();
      // Point-to-point for a zero-length segment, else the projector normal to its tangent.
      rp.projector =
          Matrix3d::Identity() -
          (point_like ? Matrix3d::Zero() : Matrix3d(pr.direction * pr.direction.transpose()));
    }
    out.push_back(rp);
  }
}

double rms(const std::vector<RigidPair>& pairs) {
  if (pairs.empty()) return 0.0;
  double s = 0.0;
  for (const auto& p : pairs) s += p.distance * p.distance;
  return std::sqrt(s / static_cast<double>(pairs.size()));
}

/// IRLS weight ρ'(s) of the Ceres loss at squared residual s.
double loss_weight(RigidInitOptions::Loss loss, double k, double s) {
  switch (loss) {
    case RigidInitOptions::Loss::HUBER:
      return s <= k * k ? 1.0 : k / std::sqrt(s);
    case RigidInitOptions::Loss::CAUCHY:
      return 1.0 / (1.0 + s / (k * k));
    case RigidInitOptions::Loss::NONE:
      return 1.0;
  }
  return 1.0;
}

/// "(x, y, z)" with 2 decimals, sign fixed so that the largest component is positive.
std::string vec_str(Vector3d v) {
  Eigen::Index imax = 0;
  v.cwiseAbs().maxCoeff(&imax);
  if (v[imax] < 0) v = -v;
  for (int i = 0; i < 3; ++i)
    if (std::abs(v[i]) < 0.005) v[i] = 0.0;  // no "-0.00"
  std::ostringstream os;
  os.setf(std::ios::fixed);
  os.precision(2);
  os << "(" << v.x() << ", " << v.y() << ", " << v.z() << ")";
  return os.str();
}

/// Scaled Gauss–Newton information matrix at the final pairs; fills condition and weak DOFs.
void observability(const std::vector<RigidPair>& pairs, const Matrix3d& R, const Vector3d& c,
                   double radius, const RigidInitOptions& o, RigidInitResult& res) {
  Eigen::Matrix<double, 6, 6> H = Eigen::Matrix<double, 6, 6>::Zero();
  for (const auto& pr : pairs) {
    const Vector3d rp = R * (pr.p - c);
    Eigen::Matrix<double, 3, 6> J;
    Matrix3d cross;
    cross << 0, -rp.z(), rp.y(), rp.z(), 0, -rp.x(), -rp.y(), rp.x(), 0;
    J.leftCols<3>() = -pr.projector * cross / radius;  // rotation, per mm of motion at the radius
    J.rightCols<3>() = pr.projector;
    const double w = (pr.plane ? o.footprint_weight : 1.0) *
                     loss_weight(o.loss, o.loss_scale_mm, pr.distance * pr.distance);
    H.noalias() += w * J.transpose() * J;
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> es(H);
  const auto& lam = es.eigenvalues();
  const double lmax = lam(5);
  if (!(lmax > 0.0)) {
    res.condition_number = 1.0 / std::numeric_limits<double>::epsilon();
    res.weak_dof_count = 6;
    res.weak_dofs = "all (no information)";
    return;
  }
  const double lmin = std::max(lam(0), lmax * std::numeric_limits<double>::epsilon());
  res.condition_number = lmax / lmin;
  std::ostringstream os;
  for (int i = 0; i < 6; ++i) {
    if (lam(i) >= o.weak_dof_ratio * lmax) continue;
    const Eigen::Matrix<double, 6, 1> v = es.eigenvectors().col(i);
    const Vector3d vr = v.head<3>(), vt = v.tail<3>();
    if (res.weak_dof_count > 0) os << ", ";
    if (vr.norm() >= vt.norm())
      os << "rotation about " << vec_str(vr.normalized());
    else
      os << "translation along " << vec_str(vt.normalized());
    ++res.weak_dof_count;
  }
  res.weak_dofs = os.str();
}

void verify_points(ConstRef<MatrixX3d> pts, const char* what) {
  BS_VERIFY(pts.allFinite(),
            what << " contain non-finite coordinates; remove them before rigid_init");
}

}  // namespace

RigidInitResult rigid_init(const core::Skeleton& skeleton, ConstRef<MatrixX3d> vessel_points,
                           const core::SurfaceMesh* surface, const MatrixX3d* footprint_points,
                           const RigidInitOptions& options) {
  const std::string bad = options.validate();
  BS_VERIFY(bad.empty(), "invalid RigidInitOptions: " << bad);
  const index_t np = static_cast<index_t>(skeleton.points.rows());
  for (std::size_t s = 0; s < skeleton.segments.size(); ++s)
    for (int k = 0; k < 2; ++k)
      BS_VERIFY(skeleton.segments[s][static_cast<std::size_t>(k)] >= 0 &&
                    skeleton.segments[s][static_cast<std::size_t>(k)] < np,
                "skeleton segment " << s << " has point index "
                                    << skeleton.segments[s][static_cast<std::size_t>(k)]
                                    << ", expected in [0, " << np << ")");
  verify_points(skeleton.points, "skeleton points");
  verify_points(vessel_points, "vessel points");
  const bool has_fp = footprint_points != nullptr && footprint_points->rows() > 0;
  BS_VERIFY(!has_fp || surface != nullptr,
            footprint_points->rows()
                << " footprint points were given without a surface; pass the core::SurfaceMesh");
  if (has_fp) {
    verify_points(*footprint_points, "footprint points");
    verify_points(surface->vertices, "surface vertices");
    const index_t nv = static_cast<index_t>(surface->vertices.rows());
    BS_VERIFY(surface->triangles.size() == 0 ||
                  (surface->triangles.minCoeff() >= 0 && surface->triangles.maxCoeff() < nv),
              "surface triangle indices out of range [0, " << nv << ")");
  }

  RigidInitResult res;
  if (vessel_points.rows() == 0) {
    res.stop_reason = "no vessel points: nothing to register (identity returned)";
    return res;
  }
  if (skeleton.segments.empty()) {
    res.stop_reason = "skeleton has no segments: nothing to pair with (identity returned)";
    return res;
  }

  const FeatureIndex seg_index = FeatureIndex::segments(skeleton.points, skeleton.segments);
  const FeatureIndex tri_index =
      has_fp ? FeatureIndex::triangles(surface->vertices, surface->triangles)
             : FeatureIndex::triangles(MatrixX3d(0, 3), {});

  // Rotation centre c and characteristic radius (RMS distance of the points from c).
  const Vector3d c = vessel_points.colwise().mean().transpose();
  double radius =
      std::sqrt((vessel_points.rowwise() - c.transpose()).rowwise().squaredNorm().mean());
  radius = std::max(radius, 1.0);  // a single point: any rotation change counts at 1 mm
  static const MatrixX3d no_points(0, 3);
  const MatrixX3d& fp = has_fp ? *footprint_points : no_points;

  auto pair_all = [&](const Matrix3d& R, const Vector3d& t) {
    std::vector<RigidPair> pairs;
    pair_points(seg_index, skeleton, vessel_points, false, R, c, t, options.max_pair_distance_mm,
                pairs);
    pair_points(tri_index, skeleton, fp, true, R, c, t, options.max_pair_distance_mm, pairs);
    return pairs;
  };

  std::unique_ptr<ceres::LossFunction> loss;
  switch (options.loss) {
    case RigidInitOptions::Loss::HUBER:
      loss = std::make_unique<ceres::HuberLoss>(options.loss_scale_mm);
      break;
    case RigidInitOptions::Loss::CAUCHY:
      loss = std::make_unique<ceres::CauchyLoss>(options.loss_scale_mm);
      break;
    case RigidInitOptions::Loss::NONE:
      break;
  }
  std::unique_ptr<ceres::LossFunction> fp_loss;
  if (has_fp)
    fp_loss = std::make_unique<ceres::ScaledLoss>(loss.get(), options.footprint_weight,
                                                  ceres::DO_NOT_TAKE_OWNERSHIP);

  Vector3d w = Vector3d::Zero(), t = Vector3d::Zero();
  std::vector<RigidPair> pairs = pair_all(Matrix3d::Identity(), t);
  res.rms_before_mm = rms(pairs);
  double change = 0.0;
  bool stopped = false;
  for (int it = 1; it <= options.max_icp_iterations; ++it) {
    if (it > 1) pairs = pair_all(rotation_of(w), t);
    index_t dof_rows = 0;
    for (const auto& pr : pairs) dof_rows += pr.plane ? 1 : 2;
    res.pairs_used = static_cast<index_t>(pairs.size());
    if (dof_rows < 6) {
      std::ostringstream os;
      os << "too few pairs within max_pair_distance_mm = " << options.max_pair_distance_mm << " ("
         << pairs.size() << " pairs, " << dof_rows << " constraint rows < 6) at ICP iteration "
         << it;
      res.stop_reason = os.str();
      stopped = true;
      break;
    }
    ceres::Problem::Options po;
    po.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    ceres::Problem problem(po);
    for (const auto& pr : pairs) {
      if (pr.plane) {
        auto* cf = new ceres::AutoDiffCostFunction<PlaneResidual, 1, 3, 3>(
            new PlaneResidual{pr.p - c, pr.q - c, pr.normal});
        problem.AddResidualBlock(cf, fp_loss.get(), w.data(), t.data());
      } else {
        auto* cf = new ceres::AutoDiffCostFunction<LineResidual, 3, 3, 3>(
            new LineResidual{pr.p - c, pr.q - c, pr.projector});
        problem.AddResidualBlock(cf, loss.get(), w.data(), t.data());
      }
    }
    const Vector3d w_old = w, t_old = t;
    ceres::Solver::Options so;
    so.linear_solver_type = ceres::DENSE_QR;
    so.max_num_iterations = options.max_solver_iterations;
    so.logging_type = ceres::SILENT;
    so.minimizer_progress_to_stdout = false;
    so.num_threads = 1;
    ceres::Solver::Summary summary;
    ceres::Solve(so, &problem, &summary);
    res.iterations = it;
    if (!summary.IsSolutionUsable() || !w.allFinite() || !t.allFinite()) {
      w = w_old;
      t = t_old;
      res.stop_reason =
          "Ceres solve failed at ICP iteration " + std::to_string(it) + ": " + summary.message;
      stopped = true;
      break;
    }
    const Matrix3d dR = rotation_of(w) * rotation_of(w_old).transpose();
    change = (t - t_old).norm() + Eigen::AngleAxisd(dR).angle() * radius;
    logger().debug("rigid_init: iteration {}, {} pairs, cost {:.6g} -> {:.6g}, change {:.3g} mm",
                   it, pairs.size(), summary.initial_cost, summary.final_cost, change);
    if (change < options.convergence_mm) {
      res.converged = true;
      std::ostringstream os;
      os << "converged: transform change " << change
         << " mm < convergence_mm = " << options.convergence_mm << " after " << it
         << " ICP iterations";
      res.stop_reason = os.str();
      stopped = true;
      break;
    }
  }
  if (!stopped) {
    std::ostringstream os;
    os << "reached max_icp_iterations = " << options.max_icp_iterations
       << " without converging (last change " << change
       << " mm ≥ convergence_mm = " << options.convergence_mm << ")";
    res.stop_reason = os.str();
  }

  const Matrix3d R = rotation_of(w);
  res.transform.linear() = R;
  res.transform.translation() = c + t - R * c;
  const std::vector<RigidPair> final_pairs = pair_all(R, t);
  res.rms_after_mm = rms(final_pairs);
  if (res.iterations > 0) res.pairs_used = static_cast<index_t>(final_pairs.size());
  observability(final_pairs, R, c, radius, options, res);
  if (res.weak_dof_count > 0) {
    std::ostringstream os;
    os << "; weakly determined (" << res.weak_dof_count << " DOF, condition "
       << res.condition_number << "): " << res.weak_dofs;
    res.stop_reason += os.str();
  }
  logger().debug("rigid_init: {}", res.stop_reason);
  return res;
}

}  // namespace brainshift::constraints
