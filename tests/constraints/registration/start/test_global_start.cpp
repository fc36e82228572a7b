// The global start (constraints/registration/start/global_start.hpp; issue 14 items 2 and 8, "each
// stage" for the start): known rigid offsets of synthetic vessel trees are recovered, a dense
// tree of parallel vessels closer together than the offset does not fool it (where robust ICP
// from the identity is fooled), no offset means no motion, 30 % outliers do not break it, a
// depth-graded bulk shift is told from a translation, and empty or tiny inputs give a clear,
// finite answer.

#include "tests/constraints/registration/vessel_trees.hpp"

#include "constraints/registration/start/global_start.hpp"
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

using namespace test_trees;  // NOLINT(google-build-using-namespace): the shared helpers

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
  const StartResult r = global_start(tree, intra, {}, GlobalStartOptions{});
  ASSERT_TRUE(r.accepted) << r.message;
  EXPECT_LT(max_error(r.transform, O.inverse(), intra), tol_mm) << r.message;
  EXPECT_FALSE(r.bulk_accepted);           // no basis given: rigid only
  EXPECT_FALSE(r.ambiguous) << r.message;  // one tree, spread in two directions
  EXPECT_EQ(r.prior_z, 0.0);               // no navigation prior by default
  // With RESECT's navigation prior (6.6 mm RMS: σ 3.8 mm per axis, so 20 mm is ≈ 5 σ) the data
  // still demand the whole offset (the prior shrinks it by ≈ σ_d²/(N σ_t²) ≈ 1e-4 of it), and
  // the report says that the pose is beyond the prior.
  GlobalStartOptions with_prior;
  with_prior.navigation_accuracy_mm = kResectNavigationAccuracyMm;
  const StartResult p = global_start(tree, intra, {}, with_prior);
  ASSERT_TRUE(p.accepted) << p.message;
  EXPECT_LT(max_error(p.transform, O.inverse(), intra), tol_mm) << p.message;
  EXPECT_GT(p.prior_z, 3.0) << p.message;
  EXPECT_NE(p.message.find("beyond"), std::string::npos) << p.message;
}

TEST(GlobalStart, RecoversA25mmFiveDegreeOffset) {
  const core::Skeleton tree = cortical_tree(3);
  const MatrixX3d pts = sample(tree, 1.0, 0.3, 4);
  const Eigen::Isometry3d O = offset(25.0, 5.0, pts.colwise().mean().transpose(), {-0.7, 0.4, 0.6});
  const MatrixX3d intra = apply(O, pts);
  const StartResult r = global_start(tree, intra, {}, GlobalStartOptions{});
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
  const StartResult r = global_start(tree, intra, {}, GlobalStartOptions{});
  ASSERT_TRUE(r.accepted) << r.message;
  EXPECT_LT(max_error(r.transform, O.inverse(), intra), tol_mm) << r.message;
}

TEST(GlobalStart, NoOffsetMeansNoMotion) {
  const core::Skeleton tree = cortical_tree(1);
  const MatrixX3d pts = sample(tree, 1.0, 0.3, 6);
  const StartResult r = global_start(tree, pts, {}, GlobalStartOptions{});
  // Either the identity is kept, or the refined pose is within the noise floor of it (see tol_mm;
  // 0.2 mm is ≈ 3× the floor and a fifth of the coarse grid's step would already fail).
  const double moved = (apply(r.transform, pts) - pts).rowwise().norm().maxCoeff();
  EXPECT_LT(moved, 0.2) << r.message;
  EXPECT_TRUE(r.transform.matrix().allFinite());
  EXPECT_LT(r.prior_z, 1.0) << r.message;
}

TEST(GlobalStart, ANavigationOffsetGainsOnEveryBlock) {
  // The significance rule (significance_z) must not cost a real offset: a 6 mm / 2° offset of
  // the cortical tree gains on every block of points, far beyond 2 standard errors.
  const core::Skeleton tree = cortical_tree(1);
  const MatrixX3d pts = sample(tree, 1.0, 0.3, 6);
  const Eigen::Isometry3d O = offset(6.0, 2.0, pts.colwise().mean().transpose());
  const MatrixX3d intra = apply(O, pts);
  const StartResult r = global_start(tree, intra, {}, GlobalStartOptions{});
  ASSERT_TRUE(r.accepted) << r.message;
  EXPECT_LT(max_error(r.transform, O.inverse(), intra), tol_mm) << r.message;
  EXPECT_GT(r.gain_z, 4.0) << r.message;
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
  const StartResult r = global_start(tree, intra, {}, GlobalStartOptions{});
  ASSERT_TRUE(r.accepted) << r.message;
  // Error measured at the clean points' true positions.
  EXPECT_LT(max_error(r.transform, O.inverse(), apply(O, pts)), tol_mm) << r.message;
}

/// The rest tree seen through a shift s that grows with height (basis α(z) I, α from 0.4 at the
/// deepest point to 1.6 at the highest, mean 1): a smooth deformation, not a pose.
struct DepthGraded {
  core::Skeleton tree = cortical_tree(1);
  MatrixX3d pts, intra;
  BasisAt basis;
  explicit DepthGraded(const Vector3d& s) : pts(sample(tree, 1.0, 0.3, 9)) {
    const double z0 = pts.col(2).minCoeff(), z1 = pts.col(2).maxCoeff();
    auto alpha = [z0, z1](double z) { return 0.4 + 1.2 * (z - z0) / (z1 - z0); };
    double mean = 0;
    for (Eigen::Index i = 0; i < pts.rows(); ++i)
      mean += alpha(pts(i, 2)) / static_cast<double>(pts.rows());
    intra = pts;
    for (Eigen::Index i = 0; i < pts.rows(); ++i)
      intra.row(i) += alpha(pts(i, 2)) / mean * s.transpose();
    basis = [alpha, mean](ConstRef<MatrixX3d> x) {
      std::vector<Matrix3d> b(static_cast<std::size_t>(x.rows()));
      for (Eigen::Index i = 0; i < x.rows(); ++i)
        b[static_cast<std::size_t>(i)] = alpha(x(i, 2)) / mean * Matrix3d::Identity();
      return b;
    };
  }
  /// Largest distance of the intra-operative points taken back to the rest by r (mm).
  [[nodiscard]] double back_to_rest_mm(const StartResult& r) const {
    MatrixX3d rest = apply(r.transform, intra);
    const std::vector<Matrix3d> b = basis(rest);
    for (Eigen::Index i = 0; i < rest.rows(); ++i)
      rest.row(i) -= (b[static_cast<std::size_t>(i)] * r.bulk_shift).transpose();
    return (rest - pts).rowwise().norm().maxCoeff();
  }
};

TEST(GlobalStart, TellsADepthGradedBulkShiftFromATranslation) {
  // With the basis the start recovers s and no rigid motion; without, a rigid pose can only
  // average it.
  const Vector3d s(8.0, -4.0, 0.0);  // horizontal: α(z) is the same at the rest and moved points
  const DepthGraded c(s);
  const StartResult r = global_start(c.tree, c.intra, c.basis, GlobalStartOptions{});
  ASSERT_TRUE(r.accepted && r.bulk_accepted) << r.message;
  // 1.5 mm: the weak prior (bulk_prior_mm) shrinks s, and a tilt of the rigid part trades
  // against the depth gradient; a start that ignores the gradient is off by ≥ 3 mm at the
  // deepest and highest points (0.6 × |s| ≈ 5.4 mm).
  EXPECT_LT((r.bulk_shift - s).norm(), 1.5) << r.message;
  EXPECT_LT(c.back_to_rest_mm(r), 1.5) << r.message;
}

TEST(GlobalStart, WhereASagAndAPoseFitAlikeThePriorsSplitTheMotionAsTheClosedFormSays) {
  // The basis is I at every point: a bulk shift s and a translation t move the points alike,
  // and the data fix only t − s = −m (m: the points' motion, 8 mm down). The maximum a
  // posteriori split under isotropic Gaussian priors of RMS lengths a (navigation) and b (sag):
  // minimise |t|²/a² + |s|²/b² on that line, t = −m a²/(a²+b²), s = m b²/(a²+b²). With
  // RESECT's navigation prior and the default sag prior (6.6 and 15 mm): 1.30 mm of pose and
  // 6.70 mm of sag. Tolerance 0.15 mm: the data pin
  // t − s to ≈ 0.06 mm (tol_mm's floor) and the priors pull it off the line by
  // ≈ |t|σ²/(a²/3) / N ≈ 1e-4 mm; the rest is the refinement's convergence (0.01 mm a round).
  const core::Skeleton tree = cortical_tree(1);
  const MatrixX3d pts = sample(tree, 1.0, 0.3, 9);
  const Vector3d m(0.0, 0.0, -8.0);
  const MatrixX3d intra = pts.rowwise() + m.transpose();
  const BasisAt identity_basis = [](ConstRef<MatrixX3d> x) {
    return std::vector<Matrix3d>(static_cast<std::size_t>(x.rows()), Matrix3d::Identity());
  };
  const Vector3d outward = Vector3d::UnitZ();  // the craniotomy on top: the brain sinks in −z
  GlobalStartOptions o;
  o.navigation_accuracy_mm = kResectNavigationAccuracyMm;
  const double a2 = o.navigation_accuracy_mm * o.navigation_accuracy_mm,
               b2 = 15.0 * 15.0;  // the sag's prior under a navigation prior (RMS, mm)
  const StartResult r = global_start(tree, intra, identity_basis, o, outward);
  ASSERT_TRUE(r.accepted && r.bulk_accepted) << r.message;
  const Vector3d cen = intra.colwise().mean().transpose();
  const Vector3d t = r.transform * cen - cen;  // the pose's translation at the points' centroid
  EXPECT_LT((t - (-m * a2 / (a2 + b2))).norm(), 0.15) << r.message;
  EXPECT_LT((r.bulk_shift - m * b2 / (a2 + b2)).norm(), 0.15) << r.message;
  EXPECT_LT(r.rotation_deg, 0.1) << r.message;
  EXPECT_LT(r.prior_z, 1.0) << r.message;  // 1.3 mm is 0.34 σ

  // Without the navigation prior (the default) the pose is free and takes the whole motion: the
  // sag is below bulk_min_mm and not kept.
  GlobalStartOptions free = o;
  free.navigation_accuracy_mm = 0.0;
  const StartResult f = global_start(tree, intra, identity_basis, free, outward);
  ASSERT_TRUE(f.accepted) << f.message;
  EXPECT_FALSE(f.bulk_accepted) << f.message;
  EXPECT_LT((f.transform * cen - cen - (-m)).norm(), 0.15) << f.message;
  EXPECT_EQ(f.prior_z, 0.0);
}

TEST(GlobalStart, TheBulkShiftSinksAwayFromTheCraniotomy) {
  // The same shift seen with a craniotomy whose outward direction it points away from (a sag):
  // the bound is inactive and the result is the unbounded one (same 1.5 mm tolerances). Seen
  // with the craniotomy on the side it points to (a bulge), the bulk shift keeps n·s ≤ 0 and
  // the rigid part takes the motion; with bulk_sinks off the bulge is found as before.
  const Vector3d s(8.0, -4.0, 0.0);
  const DepthGraded c(s);
  const Vector3d sag_outward(-0.6, 0.5, 0.8);  // n·s = −6.8 mm
  const StartResult r = global_start(c.tree, c.intra, c.basis, {}, sag_outward);
  ASSERT_TRUE(r.accepted && r.bulk_accepted) << r.message;
  EXPECT_LT((r.bulk_shift - s).norm(), 1.5) << r.message;
  EXPECT_LT(c.back_to_rest_mm(r), 1.5) << r.message;

  const Vector3d bulge_outward = s.normalized();
  const StartResult b = global_start(c.tree, c.intra, c.basis, {}, bulge_outward);
  ASSERT_TRUE(b.accepted) << b.message;
  // 1e-6 mm: the bound is exact in the rotated frame, up to the rotation back (round-off).
  EXPECT_LE(b.bulk_shift.dot(bulge_outward), 1e-6) << b.message;
  GlobalStartOptions off;
  off.bulk_sinks = false;
  const StartResult u = global_start(c.tree, c.intra, c.basis, off, bulge_outward);
  ASSERT_TRUE(u.accepted && u.bulk_accepted) << u.message;
  EXPECT_LT((u.bulk_shift - s).norm(), 1.5) << u.message;
}

TEST(GlobalStart, TwoCopiesOfATreeMakeThePoseAmbiguous) {
  // The skeleton holds the tree twice, the copy 20 mm along x; the points are the tree's, seen
  // 10 mm along x. Moving them back 10 mm or on 10 mm fits one copy or the other equally: two
  // poses 20 mm apart with the same score, which no data term can choose between (closed form:
  // the scores are equal by symmetry, ratio 1 up to the sampling of the fine points).
  const core::Skeleton tree = cortical_tree(1);
  core::Skeleton both = tree;
  for (const auto& e : tree.segments)
    add_polyline(both, {tree.points.row(e[0]).transpose() + Vector3d(20, 0, 0),
                        tree.points.row(e[1]).transpose() + Vector3d(20, 0, 0)});
  const MatrixX3d pts = sample(tree, 1.0, 0.3, 2).rowwise() + Eigen::RowVector3d(10, 0, 0);
  const StartResult r = global_start(both, pts, {}, GlobalStartOptions{});
  ASSERT_TRUE(r.accepted) << r.message;
  EXPECT_TRUE(r.ambiguous) << r.message;
  EXPECT_GT(r.runner_up_ratio, 0.9) << r.message;
  EXPECT_NEAR(r.runner_up_distance_mm, 20.0, 3.0) << r.message;  // one coarse step
  EXPECT_NE(r.message.find("ambiguous"), std::string::npos) << r.message;
}

TEST(GlobalStart, PointsAlongOneVesselLeaveARotationOpen) {
  // Points along one straight vessel (0.3 mm noise) of a tree: the rotation about the vessel
  // maps it to itself. Their spread across the vessel is the noise, far below min_spread_mm.
  core::Skeleton tree = cortical_tree(1);
  std::vector<Vector3d> line;
  for (double x = -25; x <= 25; x += 1.0) line.emplace_back(x, 30.0, 50.0);
  add_polyline(tree, line);
  core::Skeleton one;
  add_polyline(one, line);
  const MatrixX3d pts = sample(one, 1.0, 0.3, 3).rowwise() + Eigen::RowVector3d(0, 4, 2);
  const StartResult r = global_start(tree, pts, {}, GlobalStartOptions{});
  ASSERT_TRUE(r.accepted) << r.message;
  EXPECT_LT(r.spread_mm(1), 1.0) << r.message;
  EXPECT_TRUE(r.ambiguous) << r.message;
  EXPECT_NE(r.ambiguity.find("not pinned"), std::string::npos) << r.ambiguity;
}

TEST(GlobalStart, EmptyOrTooFewPointsGiveTheIdentityAndSaySo) {
  const core::Skeleton tree = cortical_tree(1);
  for (const int n : {0, 1, 5}) {
    const MatrixX3d pts = sample(tree, 1.0, 0.3, 10).topRows(n);
    const StartResult r = global_start(tree, pts, {}, GlobalStartOptions{});
    EXPECT_FALSE(r.accepted);
    EXPECT_TRUE(r.transform.isApprox(Eigen::Isometry3d::Identity()));
    EXPECT_NE(r.message.find("fewer than"), std::string::npos) << r.message;
    EXPECT_TRUE(std::isfinite(r.score) && std::isfinite(r.rms_after_mm));
  }
  const StartResult none =
      global_start(core::Skeleton{}, sample(tree, 1.0, 0.3, 10), {}, GlobalStartOptions{});
  EXPECT_FALSE(none.accepted);
  EXPECT_NE(none.message.find("no skeleton"), std::string::npos) << none.message;
}

TEST(GlobalStart, PointsFarFromEveryVesselKeepTheIdentity) {
  // Nothing within the searched range: no pose scores, the identity is kept with finite numbers.
  const core::Skeleton tree = cortical_tree(1);
  const MatrixX3d far =
      (sample(tree, 1.0, 0.3, 11).rowwise() + Vector3d(0, 0, 200).transpose()).eval();
  const StartResult r = global_start(tree, far, {}, GlobalStartOptions{});
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
