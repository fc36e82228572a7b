#include "tolerance.hpp"

#include "constraints/registration/rigid_init.hpp"
#include "core/error.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <random>
#include <vector>

namespace brainshift::constraints {
namespace {

constexpr double deg = std::numbers::pi / 180.0;
constexpr double brain_radius_mm = 60.0;
const Vector3d brain_centre(10.0, -20.0, 30.0);  // an arbitrary world position (mm, RAS)

/// Point on the brain sphere at polar angle θ from +z and azimuth φ (radians).
Vector3d on_sphere(double theta, double phi) {
  return brain_centre + brain_radius_mm * Vector3d(std::sin(theta) * std::cos(phi),
                                                   std::sin(theta) * std::sin(phi),
                                                   std::cos(theta));
}

/// Vessel-like tree on the 60 mm brain sphere: 8 branches joined at 3 bifurcations, each a
/// great-circle arc with a ±1.5 mm sinuous wiggle, as polylines of ≈ 1 mm segments (non-planar:
/// it follows the sphere over ≈ 45° of polar angle).
core::Skeleton vessel_tree() {
  struct Node {
    double theta, phi;
  };
  const std::vector<Node> nodes = {{45, 180}, {25, 180}, {8, 90},   {22, 290}, {28, 55},
                                   {22, 125}, {38, 245}, {42, 320}, {42, 140}};
  const std::vector<std::array<int, 2>> branches = {{0, 1}, {1, 2}, {1, 3}, {2, 4},
                                                    {2, 5}, {3, 6}, {3, 7}, {1, 8}};
  core::Skeleton s;
  std::vector<Vector3d> pts;
  std::vector<int> node_point(nodes.size(), -1);
  auto node_index = [&](int n) {
    if (node_point[static_cast<std::size_t>(n)] < 0) {
      const Node& nd = nodes[static_cast<std::size_t>(n)];
      pts.push_back(on_sphere(nd.theta * deg, nd.phi * deg));
      node_point[static_cast<std::size_t>(n)] = static_cast<int>(pts.size()) - 1;
    }
    return node_point[static_cast<std::size_t>(n)];
  };
  for (std::size_t b = 0; b < branches.size(); ++b) {
    const int ia = node_index(branches[b][0]), ib = node_index(branches[b][1]);
    const Vector3d ua = (pts[static_cast<std::size_t>(ia)] - brain_centre).normalized();
    const Vector3d ub = (pts[static_cast<std::size_t>(ib)] - brain_centre).normalized();
    const double angle = std::acos(std::clamp(ua.dot(ub), -1.0, 1.0));
    const int nseg = std::max(2, static_cast<int>(std::ceil(angle * brain_radius_mm / 1.0)));
    const Vector3d side = ua.cross(ub).normalized();
    int prev = ia;
    for (int k = 1; k <= nseg; ++k) {
      int cur = ib;
      if (k < nseg) {
        const double u = static_cast<double>(k) / nseg;
        const Vector3d dir =
            (std::sin((1 - u) * angle) * ua + std::sin(u * angle) * ub) / std::sin(angle);
        const double wiggle =
            1.5 * std::sin(2.0 * std::numbers::pi * u * (1.0 + static_cast<double>(b % 3)));
        pts.push_back(brain_centre +
                      brain_radius_mm * (dir + wiggle / brain_radius_mm * side).normalized());
        cur = static_cast<int>(pts.size()) - 1;
      }
      s.segments.push_back({prev, cur});
      prev = cur;
    }
  }
  s.points.resize(static_cast<Eigen::Index>(pts.size()), 3);
  for (std::size_t i = 0; i < pts.size(); ++i)
    s.points.row(static_cast<Eigen::Index>(i)) = pts[i].transpose();
  s.radius = Eigen::VectorXd::Constant(s.points.rows(), 1.0);
  return s;
}

/// Points every `step` mm of arc length along the skeleton's segments, plus N(0, σ²) noise.
MatrixX3d sample_skeleton(const core::Skeleton& s, double step, double sigma, std::mt19937& rng) {
  std::normal_distribution<double> noise(0.0, sigma);
  std::vector<Vector3d> out;
  double carry = 0.0;  // arc length left before the next sample (restarts per segment chain)
  for (const auto& e : s.segments) {
    const Vector3d a = s.points.row(e[0]).transpose(), b = s.points.row(e[1]).transpose();
    const double len = (b - a).norm();
    double at = carry;
    while (at < len) {
      out.push_back(a + (at / len) * (b - a) + Vector3d(noise(rng), noise(rng), noise(rng)));
      at += step;
    }
    carry = at - len;
  }
  MatrixX3d m(static_cast<Eigen::Index>(out.size()), 3);
  for (std::size_t i = 0; i < out.size(); ++i)
    m.row(static_cast<Eigen::Index>(i)) = out[i].transpose();
  return m;
}

/// Sphere cap around +z (|u|, |v| ≤ 45 mm, gnomonic grid every 2.5 mm), 2 triangles per cell.
core::SurfaceMesh brain_cap() {
  const int n = 37;
  const double h = 2.5, half = 45.0;
  core::SurfaceMesh m;
  m.vertices.resize(n * n, 3);
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const Vector3d d(-half + h * i, -half + h * j, brain_radius_mm);
      m.vertices.row(j * n + i) = (brain_centre + brain_radius_mm * d.normalized()).transpose();
    }
  m.triangles.resize(2 * (n - 1) * (n - 1), 3);
  int t = 0;
  for (int j = 0; j + 1 < n; ++j)
    for (int i = 0; i + 1 < n; ++i) {
      const int v = j * n + i;
      m.triangles.row(t++) << v, v + 1, v + n + 1;
      m.triangles.row(t++) << v, v + n + 1, v + n;
    }
  return m;
}

/// Footprint: `count` points on the sphere within 30 mm (gnomonic) of the pole, radial noise σ.
MatrixX3d footprint(int count, double sigma, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-30.0, 30.0);
  std::normal_distribution<double> noise(0.0, sigma);
  MatrixX3d m(count, 3);
  for (int k = 0; k < count;) {
    const double x = u(rng), y = u(rng);
    if (x * x + y * y > 900.0) continue;
    const Vector3d d = Vector3d(x, y, brain_radius_mm).normalized();
    m.row(k++) = (brain_centre + (brain_radius_mm + noise(rng)) * d).transpose();
  }
  return m;
}

/// The intra-operative offset O: 10° about a skew axis through `pivot`, then 10 mm along a
/// skew direction. Intra-operative points are O·p_pre, so the transform to recover is O⁻¹.
Eigen::Isometry3d offset(const Vector3d& pivot) {
  Eigen::Isometry3d O = Eigen::Isometry3d::Identity();
  O.translate(pivot);
  O.rotate(Eigen::AngleAxisd(10.0 * deg, Vector3d(1.0, -2.0, 0.5).normalized()));
  O.translate(-pivot);
  O.pretranslate(10.0 * Vector3d(0.3, 0.8, -0.52).normalized());
  return O;
}

MatrixX3d apply(const Eigen::Isometry3d& T, const MatrixX3d& p) {
  return ((p * T.linear().transpose()).rowwise() + T.translation().transpose()).eval();
}

struct Recovery {
  double translation_mm;  ///< |T_est c − T_true c| at the vessel points' centroid c
  double rotation_deg;    ///< angle of R_est R_trueᵀ
};

Recovery recovery(const Eigen::Isometry3d& est, const Eigen::Isometry3d& truth, const Vector3d& c) {
  return {(est * c - truth * c).norm(),
          Eigen::AngleAxisd(est.linear() * truth.linear().transpose()).angle() / deg};
}

/// One registration case: returns the recovery and prints it with the runtime.
struct Case {
  RigidInitResult result;
  Recovery rec;
  double ms;
};

Case run_case(const char* name, const core::Skeleton& skel, const MatrixX3d& vessels,
              const core::SurfaceMesh* surf, const MatrixX3d* fp, const RigidInitOptions& o,
              const Eigen::Isometry3d& truth) {
  const auto t0 = std::chrono::steady_clock::now();
  Case c{rigid_init(skel, vessels, surf, fp, o), {}, 0.0};
  c.ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  c.rec = recovery(c.result.transform, truth, vessels.colwise().mean().transpose());
  std::printf(
      "[rigid_init] %-28s %4d pts: %.4f mm, %.4f deg, %2d it, conv %d, rms %.2f->%.2f mm, cond "
      "%.3g, %.1f ms\n",
      name, static_cast<int>(vessels.rows()), c.rec.translation_mm, c.rec.rotation_deg,
      c.result.iterations, static_cast<int>(c.result.converged), c.result.rms_before_mm,
      c.result.rms_after_mm, c.result.condition_number, c.ms);
  return c;
}

// Tolerance of the recovery tests: 0.5 mm and 0.5° (the requirement). Why it is
// reachable: the optimum's scatter is σ²·H⁻¹ for the Gauss–Newton information H of the pairs.
// With N ≈ 94 points, σ = 0.3 mm per axis (two axes count for point-to-line) and the tree's
// condition number ≈ 4, the weakest combination is resolved to ≈ 0.07 mm at the RMS radius
// r ≈ 25 mm, i.e. ≈ 0.15° (1σ) of rotation and ≈ 0.05 mm of translation at the centroid; a
// sweep over 20 noise seeds gave at most 0.34° and 0.12 mm. The 1 mm polyline chords add
// < 0.01 mm. So the bound checks that ICP leaves the 10 mm / 10° start for the right basin and
// converges there, with a ≈ 3σ margin over the noise floor of this sampling.
constexpr double recover_mm = 0.5;
constexpr double recover_deg = 0.5;

struct Scene {
  core::Skeleton skel = vessel_tree();
  MatrixX3d pre_points;  // noisy samples in the pre-operative frame
  Eigen::Isometry3d O, truth;
  MatrixX3d intra;
  explicit Scene(unsigned seed) {
    std::mt19937 rng(seed);
    pre_points = sample_skeleton(skel, /*step=*/2.5, /*sigma=*/0.3, rng);
    O = offset(pre_points.colwise().mean().transpose());
    truth = O.inverse();
    intra = apply(O, pre_points);
  }
};

TEST(RigidInit, RecoversATenMillimetreTenDegreeOffsetOfABranchingTree) {
  const Scene s(1);
  ASSERT_GE(s.skel.segments.size(), 100u);
  for (auto loss : {RigidInitOptions::Loss::HUBER, RigidInitOptions::Loss::CAUCHY,
                    RigidInitOptions::Loss::NONE}) {
    SCOPED_TRACE(static_cast<int>(loss));
    RigidInitOptions o;
    o.loss = loss;
    const Case c = run_case(loss == RigidInitOptions::Loss::HUBER    ? "tree, huber"
                            : loss == RigidInitOptions::Loss::CAUCHY ? "tree, cauchy"
                                                                     : "tree, none",
                            s.skel, s.intra, nullptr, nullptr, o, s.truth);
    EXPECT_TRUE(c.result.converged) << c.result.stop_reason;
    EXPECT_LE(c.rec.translation_mm, recover_mm);
    EXPECT_LE(c.rec.rotation_deg, recover_deg);
    EXPECT_LT(c.result.rms_after_mm, c.result.rms_before_mm);
    EXPECT_LT(c.result.rms_after_mm, 1.0);  // ≈ σ√2 for point-to-curve distances with σ = 0.3 mm
    EXPECT_EQ(c.result.weak_dof_count, 0) << c.result.weak_dofs;
    EXPECT_EQ(c.result.pairs_used, s.intra.rows());
  }
}

TEST(RigidInit, RobustLossesRecoverWithThirtyPercentOutliersWhileLeastSquaresDoesWorse) {
  const Scene s(2);
  std::mt19937 rng(3);
  const Vector3d lo = s.intra.colwise().minCoeff().transpose(),
                 hi = s.intra.colwise().maxCoeff().transpose();
  const Eigen::Index n_in = s.intra.rows();
  const auto n_out =
      static_cast<Eigen::Index>(std::ceil(0.3 / 0.7 * static_cast<double>(n_in)));  // 30 % of all
  MatrixX3d pts(n_in + n_out, 3);
  pts.topRows(n_in) = s.intra;
  for (Eigen::Index k = 0; k < n_out; ++k)
    for (int d = 0; d < 3; ++d)
      pts(n_in + k, d) = std::uniform_real_distribution<double>(lo[d], hi[d])(rng);

  // Scale k = 1 mm ≈ 2.4× the 0.42 mm RMS point-to-line noise (σ√2), a usual robust scale.
  RigidInitOptions o;
  o.loss_scale_mm = 1.0;
  o.loss = RigidInitOptions::Loss::HUBER;
  const Case huber = run_case("30% outliers, huber k=1", s.skel, pts, nullptr, nullptr, o, s.truth);
  o.loss = RigidInitOptions::Loss::CAUCHY;
  const Case cauchy =
      run_case("30% outliers, cauchy k=1", s.skel, pts, nullptr, nullptr, o, s.truth);
  o.loss = RigidInitOptions::Loss::NONE;
  const Case none = run_case("30% outliers, none", s.skel, pts, nullptr, nullptr, o, s.truth);
  o.loss_scale_mm = 2.0;  // the defaults, for the report
  o.loss = RigidInitOptions::Loss::HUBER;
  run_case("30% outliers, huber k=2", s.skel, pts, nullptr, nullptr, o, s.truth);
  o.loss = RigidInitOptions::Loss::CAUCHY;
  run_case("30% outliers, cauchy k=2", s.skel, pts, nullptr, nullptr, o, s.truth);

  // Cauchy redescends: far outliers lose their pull (20-seed sweep: ≤ 0.12 mm, ≤ 0.37°).
  EXPECT_LE(cauchy.rec.translation_mm, recover_mm);
  EXPECT_LE(cauchy.rec.rotation_deg, recover_deg);
  // Huber does not: every outlier within max_pair_distance_mm pulls with a force up to k, so its
  // bias grows with k and with the outlier count (sweep: ≤ 0.24 mm, ≤ 0.80° at k = 1 mm;
  // ≤ 0.48 mm, ≤ 1.5° at k = 2 mm). Hence the looser rotation bound for Huber.
  EXPECT_LE(huber.rec.translation_mm, recover_mm);
  EXPECT_LE(huber.rec.rotation_deg, 2.0 * recover_deg);
  // Least squares is pulled by the outliers that fall within max_pair_distance of the tree.
  const auto total = [](const Case& c) { return c.rec.translation_mm + c.rec.rotation_deg; };
  EXPECT_GT(total(none), 2.0 * total(huber));
  EXPECT_GT(total(none), 2.0 * total(cauchy));
}

TEST(RigidInit, RecoversTheOffsetWithFootprintPointsOnACurvedSurface) {
  const Scene s(4);
  std::mt19937 rng(5);
  const core::SurfaceMesh cap = brain_cap();
  const MatrixX3d fp = apply(s.O, footprint(300, 0.3, rng));
  RigidInitOptions o;
  const Case c = run_case("tree + footprint, huber", s.skel, s.intra, &cap, &fp, o, s.truth);
  EXPECT_TRUE(c.result.converged) << c.result.stop_reason;
  EXPECT_LE(c.rec.translation_mm, recover_mm);
  EXPECT_LE(c.rec.rotation_deg, recover_deg);
  EXPECT_EQ(c.result.pairs_used, s.intra.rows() + fp.rows());
  EXPECT_EQ(c.result.weak_dof_count, 0) << c.result.weak_dofs;
}

TEST(RigidInit, FootprintAloneOnASphereReportsTheRotationsAboutItsCentreAsWeak) {
  // A sphere cap slides on itself under rotations about its centre: with no vessel pairs in
  // range (a far-away skeleton) those 3 DOFs are unobservable, and the report must say so.
  const Scene s(6);
  std::mt19937 rng(7);
  const core::SurfaceMesh cap = brain_cap();
  const MatrixX3d fp = footprint(300, 0.0, rng);
  core::Skeleton far = s.skel;
  far.points.rowwise() += Vector3d(500, 0, 0).transpose();
  RigidInitOptions o;
  const RigidInitResult r = rigid_init(far, s.pre_points, &cap, &fp, o);
  std::printf("[rigid_init] footprint only: %s\n", r.stop_reason.c_str());
  EXPECT_TRUE(r.transform.matrix().allFinite());
  EXPECT_GE(r.weak_dof_count, 3) << r.stop_reason;
  EXPECT_NE(r.stop_reason.find("weakly determined"), std::string::npos) << r.stop_reason;
}

TEST(RigidInit, NoPointsGiveTheIdentityAndSaySo) {
  const core::Skeleton skel = vessel_tree();
  const RigidInitResult r = rigid_init(skel, MatrixX3d(0, 3), nullptr, nullptr, RigidInitOptions{});
  EXPECT_FALSE(r.converged);
  EXPECT_TRUE(r.transform.isApprox(Eigen::Isometry3d::Identity()));
  EXPECT_NE(r.stop_reason.find("no vessel points"), std::string::npos) << r.stop_reason;
  EXPECT_EQ(r.iterations, 0);
  EXPECT_EQ(r.pairs_used, 0);
}

TEST(RigidInit, PointsOutOfReachStopWithTooFewPairs) {
  const Scene s(8);
  const MatrixX3d far = (s.intra.rowwise() + Vector3d(0, 0, 200).transpose()).eval();
  const RigidInitResult r = rigid_init(s.skel, far, nullptr, nullptr, RigidInitOptions{});
  EXPECT_FALSE(r.converged);
  EXPECT_TRUE(r.transform.isApprox(Eigen::Isometry3d::Identity()));
  EXPECT_NE(r.stop_reason.find("too few pairs"), std::string::npos) << r.stop_reason;
}

TEST(RigidInit, OneStraightVesselIsFiniteAndReportsItsUnobservableDofs) {
  // All points on one straight segment: rotation about it and translation along it leave every
  // point-to-line residual unchanged.
  core::Skeleton line;
  line.points.resize(2, 3);
  line.points << 0, 0, 0, 60, 0, 0;
  line.segments = {{0, 1}};
  MatrixX3d pts(25, 3);
  for (int k = 0; k < 25; ++k) pts.row(k) << 2.5 * k, 0.0, 0.0;
  Eigen::Isometry3d O = Eigen::Isometry3d::Identity();
  O.rotate(Eigen::AngleAxisd(5.0 * deg, Vector3d::UnitZ()));
  O.pretranslate(Vector3d(3, 2, -1));
  const MatrixX3d intra = apply(O, pts);
  for (auto loss : {RigidInitOptions::Loss::HUBER, RigidInitOptions::Loss::NONE}) {
    SCOPED_TRACE(static_cast<int>(loss));
    RigidInitOptions o;
    o.loss = loss;
    const RigidInitResult r = rigid_init(line, intra, nullptr, nullptr, o);
    std::printf("[rigid_init] straight vessel: %s\n", r.stop_reason.c_str());
    EXPECT_TRUE(r.transform.matrix().allFinite());
    EXPECT_TRUE(std::isfinite(r.rms_after_mm));
    EXPECT_TRUE(std::isfinite(r.condition_number));
    EXPECT_EQ(r.weak_dof_count, 2) << r.stop_reason;
    EXPECT_NE(r.weak_dofs.find("rotation about (1.00, 0.00, 0.00)"), std::string::npos)
        << r.weak_dofs;
    EXPECT_NE(r.weak_dofs.find("translation along"), std::string::npos) << r.weak_dofs;
    EXPECT_NE(r.stop_reason.find("weakly determined"), std::string::npos) << r.stop_reason;
    EXPECT_GT(r.condition_number, 1e6);
    // The observable part is recovered: every point lands on the line.
    const MatrixX3d back = apply(r.transform, intra);
    EXPECT_LT(back.rightCols<2>().cwiseAbs().maxCoeff(), 1e-3);  // ~ convergence_mm
  }
}

TEST(RigidInit, OptionsValidateAndBadInputsThrow) {
  RigidInitOptions o;
  EXPECT_EQ(o.validate(), "");
  o.loss_scale_mm = 0.0;
  EXPECT_NE(o.validate().find("loss_scale_mm"), std::string::npos);
  const core::Skeleton skel = vessel_tree();
  const MatrixX3d pts = skel.points.topRows(10);
  EXPECT_THROW(rigid_init(skel, pts, nullptr, nullptr, o), Error);
  core::Skeleton bad = skel;
  bad.segments.push_back({0, static_cast<index_t>(skel.points.rows())});
  EXPECT_THROW(rigid_init(bad, pts, nullptr, nullptr, RigidInitOptions{}), Error);
  const MatrixX3d fp = pts;
  EXPECT_THROW(rigid_init(skel, pts, nullptr, &fp, RigidInitOptions{}), Error);
}

}  // namespace
}  // namespace brainshift::constraints
