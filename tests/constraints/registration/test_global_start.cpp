// The global start (constraints/registration/global_start.hpp; issue 14 items 2 and 8, "each
// stage" for the start): known rigid offsets of synthetic vessel trees are recovered, a dense
// tree of parallel vessels closer together than the offset does not fool it (where robust ICP
// from the identity is fooled), no offset means no motion, 30 % outliers do not break it, a
// depth-graded bulk shift is told from a translation, and empty or tiny inputs give a clear,
// finite answer.

#include "constraints/registration/global_start.hpp"
#include "constraints/registration/rigid_init.hpp"
#include "core/error.hpp"
#include "data_synth/geometry/structured_mesh.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <numbers>
#include <random>
#include <vector>

namespace brainshift::constraints {
namespace {

constexpr double deg = std::numbers::pi / 180.0;

/// Appends a polyline (points joined in order) to a skeleton.
void add_polyline(core::Skeleton& s, const std::vector<Vector3d>& line) {
  const auto first = static_cast<index_t>(s.points.rows());
  s.points.conservativeResize(first + static_cast<Eigen::Index>(line.size()), 3);
  for (std::size_t k = 0; k < line.size(); ++k)
    s.points.row(first + static_cast<Eigen::Index>(k)) = line[k].transpose();
  for (std::size_t k = 1; k < line.size(); ++k)
    s.segments.push_back({first + static_cast<index_t>(k) - 1, first + static_cast<index_t>(k)});
}

/// A cortical-like tree on a 60 mm sphere (centre at the origin, cap around +z): 3 roots, two
/// generations of bifurcations, each branch a wiggly arc of 1 mm segments (≈ 20 branches).
core::Skeleton cortical_tree(unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  core::Skeleton s;
  s.points.resize(0, 3);
  const double R = 60.0;
  auto on_sphere = [&](const Vector3d& d) { return Vector3d(R * d.normalized()); };
  struct Start {
    Vector3d at, dir;
    int gen;
  };
  std::vector<Start> todo;
  for (int r = 0; r < 3; ++r) {
    const double phi = 2 * std::numbers::pi * r / 3 + 0.3;
    todo.push_back({on_sphere(Vector3d(0.6 * std::cos(phi), 0.6 * std::sin(phi), 1)),
                    Vector3d(-std::cos(phi), -std::sin(phi), 0).normalized(), 0});
  }
  while (!todo.empty()) {
    const Start b = todo.back();
    todo.pop_back();
    const double len = 18.0 + 12.0 * u(rng), amp = 1.0 + u(rng), wave = 8.0 + 8.0 * u(rng);
    std::vector<Vector3d> line;
    Vector3d p = b.at, d = b.dir;
    for (double l = 0; l <= len; l += 1.0) {
      const Vector3d n = p.normalized();
      const Vector3d side = n.cross(d).normalized();
      line.push_back(on_sphere(p + amp * std::sin(2 * std::numbers::pi * l / wave) * side));
      d = (d - d.dot(n) * n).normalized();
      p = on_sphere(p + d);
    }
    add_polyline(s, line);
    if (b.gen < 2)
      for (const double turn : {-0.6, 0.6}) {
        const Vector3d n = line.back().normalized();
        const Vector3d dd = Eigen::AngleAxisd(turn, n) * d;
        todo.push_back({line.back(), dd, b.gen + 1});
      }
  }
  return s;
}

/// Parallel wavy vessels spaced `spacing` mm along y on a gently curved sheet (z ≈ 60 mm), each
/// with its own wavelength and phase, and one vessel crossing them: a dense tree.
core::Skeleton parallel_vessels(int count, double spacing) {
  core::Skeleton s;
  s.points.resize(0, 3);
  auto sheet = [](double x, double y) { return Vector3d(x, y, 60.0 - (x * x + y * y) / 120.0); };
  for (int k = 0; k < count; ++k) {
    const double y0 = (k - 0.5 * (count - 1)) * spacing, wave = 9.0 + 1.7 * k, phase = 0.9 * k;
    std::vector<Vector3d> line;
    for (double x = -30; x <= 30; x += 1.0)
      line.push_back(sheet(x, y0 + 0.8 * std::sin(2 * std::numbers::pi * x / wave + phase)));
    add_polyline(s, line);
  }
  std::vector<Vector3d> cross;
  for (double y = -0.5 * count * spacing; y <= 0.5 * count * spacing; y += 1.0)
    cross.push_back(sheet(-12.0 + 0.3 * y, y));
  add_polyline(s, cross);
  return s;
}

/// Points every `step` mm along the segments with N(0, σ²) noise per axis.
MatrixX3d sample(const core::Skeleton& s, double step, double sigma, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, sigma);
  std::vector<Vector3d> out;
  double carry = 0.0;
  for (const auto& e : s.segments) {
    const Vector3d a = s.points.row(e[0]).transpose(), b = s.points.row(e[1]).transpose();
    const double len = (b - a).norm();
    double at = carry;
    for (; at < len; at += step)
      out.push_back(a + (at / len) * (b - a) + Vector3d(noise(rng), noise(rng), noise(rng)));
    carry = at - len;
  }
  MatrixX3d m(static_cast<Eigen::Index>(out.size()), 3);
  for (std::size_t i = 0; i < out.size(); ++i)
    m.row(static_cast<Eigen::Index>(i)) = out[i].transpose();
  return m;
}

/// The tracking offset O (rotation `angle_deg` about a skew axis through `pivot`, then a
/// translation of `mm` along a skew direction): intra-operative points are O·p_model, so the
/// start must return O⁻¹.
Eigen::Isometry3d offset(double mm, double angle_deg, const Vector3d& pivot,
                         const Vector3d& dir = {0.5, 0.8, -0.33}) {
  Eigen::Isometry3d O = Eigen::Isometry3d::Identity();
  O.translate(pivot);
  O.rotate(Eigen::AngleAxisd(angle_deg * deg, Vector3d(1.0, -2.0, 0.5).normalized()));
  O.translate(-pivot);
  O.pretranslate(mm * dir.normalized());
  return O;
}

MatrixX3d apply(const Eigen::Isometry3d& T, const MatrixX3d& p) {
  return ((p * T.linear().transpose()).rowwise() + T.translation().transpose()).eval();
}

/// Largest distance between where the estimate and the truth put the model points (mm).
double max_error(const Eigen::Isometry3d& est, const Eigen::Isometry3d& truth,
                 const MatrixX3d& intra) {
  return (apply(est, intra) - apply(truth, intra)).rowwise().norm().maxCoeff();
}

// Tolerance of the recoveries: 0.5 mm at every point. The refinement is a robust least-squares
// fit of ≈ 400–600 points with 0.3 mm noise per axis over a field ≈ 60 mm across: the pose's
// scatter at the field's edge is ≈ 0.3 / √(N/6) · 2 ≈ 0.06 mm, the 1 mm chords of the polylines
// add < 0.01 mm; 0.5 mm is ≈ 8× that floor, and far below the ≥ 4 mm error of a wrong basin (the
// next vessel, or a 1° rotation error at 30 mm ≈ 0.5 mm).
constexpr double tol_mm = 0.5;

TEST(GlobalStart, RecoversA20mmFourDegreeOffsetOfACorticalTree) {
  const core::Skeleton tree = cortical_tree(1);
  const MatrixX3d pts = sample(tree, 1.0, 0.3, 2);
  const Eigen::Isometry3d O = offset(20.0, 4.0, pts.colwise().mean().transpose());
  const MatrixX3d intra = apply(O, pts);
  const GlobalStartResult r = global_start(tree, intra, {}, GlobalStartOptions{});
  ASSERT_TRUE(r.accepted) << r.message;
  EXPECT_LT(max_error(r.transform, O.inverse(), intra), tol_mm) << r.message;
  EXPECT_FALSE(r.bulk_accepted);  // no basis given: rigid only
}

TEST(GlobalStart, RecoversA25mmFiveDegreeOffset) {
  const core::Skeleton tree = cortical_tree(3);
  const MatrixX3d pts = sample(tree, 1.0, 0.3, 4);
  const Eigen::Isometry3d O = offset(25.0, 5.0, pts.colwise().mean().transpose(), {-0.7, 0.4, 0.6});
  const MatrixX3d intra = apply(O, pts);
  const GlobalStartResult r = global_start(tree, intra, {}, GlobalStartOptions{});
  ASSERT_TRUE(r.accepted) << r.message;
  EXPECT_LT(max_error(r.transform, O.inverse(), intra), tol_mm) << r.message;
  EXPECT_NEAR(r.translation_mm, 25.0,
              5.0);  // the offset is 25 mm at its pivot, the points' centroid
}

TEST(GlobalStart, ADenseTreeOfParallelVesselsDoesNotFoolIt) {
  // 12 vessels 4 mm apart, offset 20 mm / 4° mostly across them: the nearest vessel of every
  // point is a wrong one, five spacings away.
  const core::Skeleton tree = parallel_vessels(12, 4.0);
  const MatrixX3d pts = sample(tree, 1.0, 0.3, 5);
  const Eigen::Isometry3d O = offset(20.0, 4.0, pts.colwise().mean().transpose(), {0.2, 1.0, 0.1});
  const MatrixX3d intra = apply(O, pts);
  const GlobalStartResult r = global_start(tree, intra, {}, GlobalStartOptions{});
  ASSERT_TRUE(r.accepted) << r.message;
  EXPECT_LT(max_error(r.transform, O.inverse(), intra), tol_mm) << r.message;
  // The control: robust ICP from the identity settles on other vessels (why the search exists).
  RigidInitOptions ro;
  ro.loss = RigidInitOptions::Loss::CAUCHY;
  const RigidInitResult icp = rigid_init(tree, intra, nullptr, nullptr, ro);
  EXPECT_GT(max_error(icp.transform, O.inverse(), intra), 2.0)
      << "the scene should fool ICP: " << icp.stop_reason;
}

TEST(GlobalStart, NoOffsetMeansNoMotion) {
  const core::Skeleton tree = cortical_tree(1);
  const MatrixX3d pts = sample(tree, 1.0, 0.3, 6);
  const GlobalStartResult r = global_start(tree, pts, {}, GlobalStartOptions{});
  // Either the identity is kept, or the refined pose is within the noise floor of it (see tol_mm;
  // 0.2 mm is ≈ 3× the floor and a fifth of the coarse grid's step would already fail).
  const double moved = (apply(r.transform, pts) - pts).rowwise().norm().maxCoeff();
  EXPECT_LT(moved, 0.2) << r.message;
  EXPECT_TRUE(r.transform.matrix().allFinite());
}

TEST(GlobalStart, ThirtyPercentOutliersDoNotBreakIt) {
  const core::Skeleton tree = cortical_tree(2);
  MatrixX3d pts = sample(tree, 1.0, 0.3, 7);
  const Eigen::Isometry3d O = offset(15.0, 4.0, pts.colwise().mean().transpose());
  MatrixX3d intra = apply(O, pts);
  // 30 % of the points replaced by uniform clutter over the points' bounding box (plus 10 mm).
  std::mt19937 rng(8);
  const Vector3d lo = intra.colwise().minCoeff().transpose().array() - 10,
                 hi = intra.colwise().maxCoeff().transpose().array() + 10;
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (Eigen::Index i = 0; i < intra.rows(); ++i)
    if (u(rng) < 0.3)
      intra.row(i) = (lo.array() + (hi - lo).array() * Vector3d(u(rng), u(rng), u(rng)).array())
                         .matrix()
                         .transpose();
  const GlobalStartResult r = global_start(tree, intra, {}, GlobalStartOptions{});
  ASSERT_TRUE(r.accepted) << r.message;
  // Error measured at the clean points' true positions.
  EXPECT_LT(max_error(r.transform, O.inverse(), apply(O, pts)), tol_mm) << r.message;
}

TEST(GlobalStart, TellsADepthGradedBulkShiftFromATranslation) {
  // The rest tree seen through a shift s that grows with height (basis α(z) I, α from 0.4 at
  // the deepest point to 1.6 at the highest, mean 1): a smooth deformation, not a pose. With the
  // basis the start recovers s and no rigid motion; without, a rigid pose can only average it.
  const core::Skeleton tree = cortical_tree(1);
  const MatrixX3d pts = sample(tree, 1.0, 0.3, 9);
  const double z0 = pts.col(2).minCoeff(), z1 = pts.col(2).maxCoeff();
  auto alpha = [&](double z) { return 0.4 + 1.2 * (z - z0) / (z1 - z0); };
  double mean = 0;
  for (Eigen::Index i = 0; i < pts.rows(); ++i)
    mean += alpha(pts(i, 2)) / static_cast<double>(pts.rows());
  const Vector3d s(8.0, -4.0, 0.0);  // horizontal: α(z) is the same at the rest and moved points
  MatrixX3d intra = pts;
  for (Eigen::Index i = 0; i < pts.rows(); ++i)
    intra.row(i) += alpha(pts(i, 2)) / mean * s.transpose();
  const BasisAt basis = [&](ConstRef<MatrixX3d> x) {
    std::vector<Matrix3d> b(static_cast<std::size_t>(x.rows()));
    for (Eigen::Index i = 0; i < x.rows(); ++i)
      b[static_cast<std::size_t>(i)] = alpha(x(i, 2)) / mean * Matrix3d::Identity();
    return b;
  };
  const GlobalStartResult r = global_start(tree, intra, basis, GlobalStartOptions{});
  ASSERT_TRUE(r.accepted && r.bulk_accepted) << r.message;
  // 1.5 mm: the weak prior (bulk_prior_mm) shrinks s, and a tilt of the rigid part trades
  // against the depth gradient; a start that ignores the gradient is off by ≥ 3 mm at the
  // deepest and highest points (0.6 × |s| ≈ 5.4 mm).
  EXPECT_LT((r.bulk_shift - s).norm(), 1.5) << r.message;
  MatrixX3d rest = apply(r.transform, intra);
  const std::vector<Matrix3d> b = basis(rest);
  for (Eigen::Index i = 0; i < rest.rows(); ++i)
    rest.row(i) -= (b[static_cast<std::size_t>(i)] * r.bulk_shift).transpose();
  EXPECT_LT((rest - pts).rowwise().norm().maxCoeff(), 1.5) << r.message;
}

TEST(GlobalStart, EmptyOrTooFewPointsGiveTheIdentityAndSaySo) {
  const core::Skeleton tree = cortical_tree(1);
  for (const int n : {0, 1, 5}) {
    const MatrixX3d pts = sample(tree, 1.0, 0.3, 10).topRows(n);
    const GlobalStartResult r = global_start(tree, pts, {}, GlobalStartOptions{});
    EXPECT_FALSE(r.accepted);
    EXPECT_TRUE(r.transform.isApprox(Eigen::Isometry3d::Identity()));
    EXPECT_NE(r.message.find("fewer than"), std::string::npos) << r.message;
    EXPECT_TRUE(std::isfinite(r.score) && std::isfinite(r.rms_after_mm));
  }
  const GlobalStartResult none =
      global_start(core::Skeleton{}, sample(tree, 1.0, 0.3, 10), {}, GlobalStartOptions{});
  EXPECT_FALSE(none.accepted);
  EXPECT_NE(none.message.find("no skeleton"), std::string::npos) << none.message;
}

TEST(GlobalStart, PointsFarFromEveryVesselKeepTheIdentity) {
  // Nothing within the searched range: no pose scores, the identity is kept with finite numbers.
  const core::Skeleton tree = cortical_tree(1);
  const MatrixX3d far =
      (sample(tree, 1.0, 0.3, 11).rowwise() + Vector3d(0, 0, 200).transpose()).eval();
  const GlobalStartResult r = global_start(tree, far, {}, GlobalStartOptions{});
  EXPECT_FALSE(r.accepted) << r.message;
  EXPECT_TRUE(r.transform.isApprox(Eigen::Isometry3d::Identity()));
  EXPECT_TRUE(std::isfinite(r.score) && std::isfinite(r.rms_before_mm));
}

TEST(GlobalStart, OptionsValidateAndNonFiniteInputsThrow) {
  GlobalStartOptions o;
  EXPECT_TRUE(o.validate().empty()) << o.validate();
  o.coarse_step_mm = 2 * o.coarse_kernel_mm;
  EXPECT_NE(o.validate().find("coarse_step_mm"), std::string::npos);
  MatrixX3d pts = sample(cortical_tree(1), 1.0, 0.3, 12);
  EXPECT_THROW((void)global_start(cortical_tree(1), pts, {}, o), Error);
  pts(3, 1) = std::nan("");
  EXPECT_THROW((void)global_start(cortical_tree(1), pts, {}, GlobalStartOptions{}), Error);
}

TEST(LoadBasis, TheGridSearchPicksTheNodeALinearScanPicks) {
  // load_basis finds each point's nearest rest node through a grid (speed at 20k nodes); the
  // answer must be the linear scan's, ties to the lowest index, for points inside, on nodes
  // (distance 0) and far outside the mesh.
  const core::TetMesh mesh = data_synth::make_ellipsoid_mesh({40, 35, 30}, 6);
  std::array<MatrixX3d, 3> response;
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (auto& r : response) {
    r.resize(mesh.num_nodes(), 3);
    for (Eigen::Index i = 0; i < r.size(); ++i) r.data()[i] = 1.0 + 0.5 * u(rng);
  }
  MatrixX3d pts(300, 3);
  for (Eigen::Index i = 0; i < pts.rows(); ++i) {
    const double reach = i < 100 ? 40.0 : (i < 200 ? 120.0 : 0.0);  // inside, outside, on nodes
    pts.row(i) = reach > 0 ? Vector3d(reach * u(rng), reach * u(rng), reach * u(rng)).transpose()
                           : mesh.nodes().row((i * 37) % mesh.num_nodes()).eval();
  }
  const std::vector<Matrix3d> got = load_basis(mesh, response, pts);
  ASSERT_EQ(got.size(), static_cast<std::size_t>(pts.rows()));
  // Reference: the linear scan, then the same normalisation by the mean.
  std::vector<Matrix3d> ref(got.size());
  Matrix3d mean = Matrix3d::Zero();
  for (Eigen::Index i = 0; i < pts.rows(); ++i) {
    Eigen::Index node = 0;
    (mesh.nodes().rowwise() - pts.row(i)).rowwise().squaredNorm().minCoeff(&node);
    for (int k = 0; k < 3; ++k)
      ref[static_cast<std::size_t>(i)].col(k) =
          response[static_cast<std::size_t>(k)].row(node).transpose();
    mean += ref[static_cast<std::size_t>(i)] / static_cast<double>(pts.rows());
  }
  for (std::size_t i = 0; i < ref.size(); ++i)
    EXPECT_TRUE((got[i].array() == (ref[i] * mean.inverse()).array()).all())
        << "point " << i;  // the same node gives the same matrix, bit for bit
}

}  // namespace
}  // namespace brainshift::constraints
