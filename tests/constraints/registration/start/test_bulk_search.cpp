// Bulk-shift search: a dense lattice of vessels closer together than the shift, so that the
// nearest-feature pairing at the rest shape would pick the neighbouring vessel.
#include "constraints/registration/start/bulk_search.hpp"
#include "constraints/registration/start/distance_grid.hpp"
#include "constraints/registration/start/global_start.hpp"
#include "core/error.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

namespace brainshift::constraints {
namespace {

/// Vessels 2.5 mm apart along x (varying in z) crossed by a few along y, in a 40 mm patch.
core::Skeleton vessel_lattice() {
  core::Skeleton s;
  std::vector<Vector3d> pts;
  auto line = [&](const Vector3d& a, const Vector3d& b, int n) {
    const auto first = static_cast<index_t>(pts.size());
    for (int k = 0; k <= n; ++k) pts.push_back(a + (b - a) * (static_cast<double>(k) / n));
    for (int k = 0; k < n; ++k) s.segments.push_back({first + k, first + k + 1});
  };
  for (int j = 0; j < 16; ++j) {
    const double y = -20.0 + 2.5 * j + 0.7 * std::sin(j);
    line(Vector3d(-20, y, 1.5 * std::sin(0.5 * j)), Vector3d(20, y, -1.5 * std::cos(0.3 * j)), 20);
  }
  for (int i = 0; i < 4; ++i) {
    const double x = -15.0 + 9.0 * i;
    line(Vector3d(x, -20, 3.0), Vector3d(x + 4.0, 20, 2.0 - i), 20);
  }
  s.points.resize(static_cast<Eigen::Index>(pts.size()), 3);
  for (std::size_t i = 0; i < pts.size(); ++i)
    s.points.row(static_cast<Eigen::Index>(i)) = pts[i].transpose();
  return s;
}

/// Points on the lattice moved by `shift`, with 0.3 mm noise, keeping the middle of the patch.
MatrixX3d seen(const core::Skeleton& s, const Vector3d& shift) {
  std::mt19937 rng(11);
  std::normal_distribution<double> g(0.0, 0.3);
  std::vector<Vector3d> out;
  for (Eigen::Index i = 0; i < s.points.rows(); ++i) {
    const Vector3d p = s.points.row(i).transpose();
    if (std::abs(p.x()) > 14 || std::abs(p.y()) > 14) continue;
    out.push_back(p + shift + Vector3d(g(rng), g(rng), g(rng)));
  }
  MatrixX3d m(static_cast<Eigen::Index>(out.size()), 3);
  for (std::size_t i = 0; i < out.size(); ++i)
    m.row(static_cast<Eigen::Index>(i)) = out[i].transpose();
  return m;
}

TEST(BulkSearch, FindsAShiftLargerThanTheVesselSpacing) {
  const core::Skeleton s = vessel_lattice();
  const Vector3d shift(1.0, -1.5, -8.0);
  const StartResult r = search_bulk_shift(s, seen(s, shift), {}, BulkSearchOptions{});
  EXPECT_TRUE(r.bulk_accepted) << r.bulk_message;
  EXPECT_LT((r.bulk_shift - shift).norm(), 0.75) << r.bulk_message;
  EXPECT_GT(r.score, r.score_identity);
}

TEST(BulkSearch, ABasisScalesTheShiftPerPoint) {
  // Each point moves by half the searched shift: with basis ½I the search reports the full one.
  const core::Skeleton s = vessel_lattice();
  const Vector3d shift(0.0, 1.0, -6.0);
  const MatrixX3d p = seen(s, 0.5 * shift);
  const std::vector<Matrix3d> half(static_cast<std::size_t>(p.rows()), 0.5 * Matrix3d::Identity());
  const StartResult r = search_bulk_shift(s, p, half, BulkSearchOptions{});
  EXPECT_TRUE(r.bulk_accepted) << r.bulk_message;
  EXPECT_LT((r.bulk_shift - shift).norm(), 1.0) << r.bulk_message;
}

TEST(BulkSearch, NothingToMatchIsNotAccepted) {
  const core::Skeleton s = vessel_lattice();
  BulkSearchOptions o;
  EXPECT_FALSE(search_bulk_shift(core::Skeleton{}, seen(s, Vector3d::Zero()), {}, o).bulk_accepted);
  EXPECT_FALSE(search_bulk_shift(s, MatrixX3d(0, 3), {}, o).bulk_accepted);
  // Points already in place: no shift beats zero by the required gain.
  const StartResult r = search_bulk_shift(s, seen(s, Vector3d::Zero()), {}, o);
  EXPECT_FALSE(r.bulk_accepted && r.bulk_shift.norm() > 0.75) << r.bulk_message;
  o.min_gain = 0.5;
  EXPECT_THROW(search_bulk_shift(s, seen(s, Vector3d::Zero()), {}, o), brainshift::Error);
}

TEST(BulkSearch, AKnownPoseIsKeptAndTheShiftIsFoundInItsFrame) {
  // The tracked frame is off by a known pose (as a pre-dura sweep measures it): points at
  // pose⁻¹ (skeleton + shift). start_at_pose places them by the pose and searches the shift alone;
  // the answer is the shift that was applied (to the search's 0.75 mm, as above) and the pose
  // itself, untouched.
  const core::Skeleton s = vessel_lattice();
  const Vector3d shift(-1.0, 0.5, -7.0);
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = Eigen::AngleAxisd(0.1, Vector3d(0.3, -0.2, 1.0).normalized()).toRotationMatrix();
  pose.translation() = Vector3d(12.0, -4.0, 6.0);
  const MatrixX3d in_model = seen(s, shift);
  MatrixX3d tracked(in_model.rows(), 3);
  for (Eigen::Index i = 0; i < in_model.rows(); ++i)
    tracked.row(i) = (pose.inverse() * Vector3d(in_model.row(i).transpose())).transpose();
  const GlobalStartOptions o;
  const StartResult r = start_at_pose(s, tracked, pose, {}, o, true, "given");
  EXPECT_TRUE(r.transform.isApprox(pose, 0.0));
  EXPECT_TRUE(r.converged);
  EXPECT_FALSE(r.accepted);  // the pose was given, not searched
  EXPECT_EQ(r.stop_reason, "given");
  EXPECT_TRUE(r.bulk_accepted) << r.bulk_message;
  EXPECT_LT((r.bulk_shift - shift).norm(), 0.75) << r.bulk_message;
  // Not searched: the pose alone, no bulk shift and no message.
  const StartResult p = start_at_pose(s, tracked, pose, {}, o, false, "given");
  EXPECT_FALSE(p.bulk_accepted);
  EXPECT_TRUE(p.bulk_message.empty()) << p.bulk_message;
  EXPECT_TRUE(p.bulk_shift.isZero());
}

/// The bulk search as it was written first, without its shortcuts: the whole distance grid,
/// every point's nearest() term added, shift after shift, then the fine grid. The same options'
/// geometry (margin, grid, stride), so the search must return its very numbers.
StartResult reference_bulk_search(const core::Skeleton& skeleton, const MatrixX3d& points,
                                  const std::vector<Matrix3d>& basis, const BulkSearchOptions& o) {
  const double R = o.radius_mm, tc = o.coarse_kernel_mm, tf = o.fine_kernel_mm;
  double reach = 1.0;
  for (const Matrix3d& b : basis) reach = std::max(reach, b.operatorNorm());
  const double margin = reach * R * std::sqrt(3.0) + tc + o.voxel_mm;
  const Vector3d lo = points.colwise().minCoeff().transpose().array() - margin;
  const Vector3d hi = points.colwise().maxCoeff().transpose().array() + margin;
  const detail::DistanceGrid table(skeleton, lo, hi, o.voxel_mm, tc);
  const Eigen::Index stride = (points.rows() + o.max_points - 1) / o.max_points;
  const Eigen::Index n = (points.rows() + stride - 1) / stride;
  const auto moved = [&](Eigen::Index j, const Vector3d& s) -> Vector3d {
    const Eigen::Index i = j * stride;
    return points.row(i).transpose() -
           (basis.empty() ? s : Vector3d(basis[static_cast<std::size_t>(i)] * s));
  };
  const auto score = [&](const Vector3d& s, bool coarse) {
    double sum = 0;
    for (Eigen::Index i = 0; i < n; ++i)
      sum += coarse ? std::max(0.0, 1.0 - table.nearest(moved(i, s)) / (tc * tc))
                    : std::max(0.0, 1.0 - table.trilinear(moved(i, s)) / (tf * tf));
    return sum;
  };
  const int k = static_cast<int>(std::floor(R / o.coarse_step_mm));
  Vector3d best = Vector3d::Zero();
  double best_score = -1;
  for (int z = -k; z <= k; ++z)
    for (int y = -k; y <= k; ++y)
      for (int x = -k; x <= k; ++x) {
        const Vector3d s = o.coarse_step_mm * Vector3d(x, y, z);
        const double sc = score(s, true);
        if (sc > best_score + 1e-9 || (sc > best_score - 1e-9 && s.norm() < best.norm())) {
          best_score = sc;
          best = s;
        }
      }
  const Vector3d centre = best;
  double fine_best = score(centre, false);
  const double h = o.coarse_step_mm / 4;
  for (int z = -4; z <= 4; ++z)
    for (int y = -4; y <= 4; ++y)
      for (int x = -4; x <= 4; ++x) {
        const Vector3d s = centre + h * Vector3d(x, y, z);
        if (const double sc = score(s, false); sc > fine_best) {
          fine_best = sc;
          best = s;
        }
      }
  StartResult r;
  r.score = fine_best;
  r.score_identity = score(Vector3d::Zero(), false);
  r.bulk_shift = best;
  return r;
}

TEST(BulkSearch, GivesThePlainSearchsNumbersToTheBit) {
  // The coarse scan skips the voxels beyond τ on a bit mask, rounds without std::round and sums
  // point by point on threads: none of it may change a score. Against the plain search above,
  // with and without a per-point basis (each point moving by its own 3×3 response), the coarse
  // scores, the best shift, its score and the score at zero must be the same doubles.
  const core::Skeleton s = vessel_lattice();
  const MatrixX3d p = seen(s, Vector3d(1.0, -1.5, -8.0));
  std::vector<Matrix3d> basis;
  for (Eigen::Index i = 0; i < p.rows(); ++i) {
    Matrix3d b = 0.7 * Matrix3d::Identity();
    b(0, 2) = 0.05 * std::sin(0.3 * static_cast<double>(i));
    b(2, 2) += 0.1 * std::cos(0.2 * static_cast<double>(i));
    basis.push_back(b);
  }
  for (const auto& B : {std::vector<Matrix3d>{}, basis}) {
    BulkSearchOptions o;
    o.radius_mm = 14.0;  // a 29³ grid of shifts (the scaled shift is 11.4 mm deep): short
    // The coarse scores themselves (which only pick the fine search's centre, so the answer
    // below would hide most changes to them): every one the plain sum over the whole grid's
    // nearest(), to the bit, every second point (a stride).
    {
      const double tau = o.coarse_kernel_mm, step = o.coarse_step_mm;
      const int k = 14;
      const Vector3d lo = p.colwise().minCoeff().transpose().array() - 30.0;
      const Vector3d hi = p.colwise().maxCoeff().transpose().array() + 30.0;
      const detail::DistanceGrid whole(s, lo, hi, o.voxel_mm, tau);
      const detail::DistanceGrid near(s, lo, hi, o.voxel_mm, tau, /*stored_near_skeleton=*/true);
      const std::vector<double> scores = detail::coarse_shift_scores(near, p, B, 2, k, step, tau);
      std::size_t c = 0, positive = 0;
      for (int z = -k; z <= k; ++z)
        for (int y = -k; y <= k; ++y)
          for (int x = -k; x <= k; ++x, ++c) {
            const Vector3d sh = step * Vector3d(x, y, z);
            double plain = 0;
            for (Eigen::Index i = 0; i < p.rows(); i += 2) {
              const Vector3d q = p.row(i).transpose() -
                                 (B.empty() ? sh : Vector3d(B[static_cast<std::size_t>(i)] * sh));
              plain += std::max(0.0, 1.0 - whole.nearest(q) / (tau * tau));
            }
            ASSERT_EQ(scores[c], plain) << "shift " << sh.transpose();
            positive += plain > 0;
          }
      ASSERT_EQ(c, scores.size());
      // A stride of 0 or a basis of the wrong size: an error, not a division by zero.
      EXPECT_THROW((void)detail::coarse_shift_scores(near, p, B, 0, k, step, tau),
                   brainshift::Error);
      EXPECT_THROW(
          (void)detail::coarse_shift_scores(near, p, std::vector<Matrix3d>(3), 1, k, step, tau),
          brainshift::Error);
      EXPECT_GT(positive, scores.size() / 4);  // many shifts reach a vessel: sums of many terms
    }
    const StartResult r = search_bulk_shift(s, p, B, o);
    const StartResult ref = reference_bulk_search(s, p, B, o);
    EXPECT_EQ(r.score, ref.score) << r.bulk_message;
    EXPECT_EQ(r.score_identity, ref.score_identity) << r.bulk_message;
    ASSERT_TRUE(r.bulk_accepted) << r.bulk_message;
    EXPECT_EQ(r.bulk_shift, ref.bulk_shift) << r.bulk_message;
  }
}

TEST(DistanceGrid, StoredNearTheSkeletonAnswersAsTheWholeGrid) {
  // The bulk search's box is much larger than the skeleton; its table stores only the voxels
  // near the segments. The answer must be the whole grid's, to the bit: at random points of the
  // box, near the vessels, near the stored window's edges and outside the grid.
  const core::Skeleton s = vessel_lattice();
  const Vector3d lo(-70, -65, -60), hi(75, 70, 66);
  const double h = 0.5, tau = 3.0;
  const detail::DistanceGrid whole(s, lo, hi, h, tau);
  const detail::DistanceGrid near(s, lo, hi, h, tau, /*stored_near_skeleton=*/true);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-80.0, 80.0), v(-27.0, 27.0), w(-8.0, 8.0);
  int checked = 0;
  for (int i = 0; i < 200000; ++i) {
    const Vector3d q = i % 2 ? Vector3d(u(rng), u(rng), u(rng)) : Vector3d(v(rng), v(rng), w(rng));
    ASSERT_EQ(near.nearest(q), whole.nearest(q)) << q.transpose();
    ASSERT_EQ(near.trilinear(q), whole.trilinear(q)) << q.transpose();
    ASSERT_EQ(near.segment(q), whole.segment(q)) << q.transpose();
    // The bulk search's lookup: a voxel within τ, with nearest()'s value, exactly when nearest()
    // is below τ² (elsewhere the kernel is ≤ 0 and the search adds nothing).
    for (const detail::DistanceGrid* g : {&near, &whole}) {
      double d2 = -1;
      ASSERT_EQ(g->nearest_within_tau(q, d2), whole.nearest(q) < tau * tau) << q.transpose();
      if (whole.nearest(q) < tau * tau) {
        ASSERT_EQ(d2, whole.nearest(q)) << q.transpose();
      }
    }
    // The voxel is std::round's, as it was before the rounding lost its library call.
    ASSERT_EQ(near.nearest_cell(q), ((q - lo) / h).array().round().cast<int>().matrix());
    checked += whole.nearest(q) < tau * tau;
  }
  EXPECT_GT(checked, 1000);  // many of the points are near a vessel, not all far
}

TEST(DistanceGrid, RoundsHalvesAwayFromZeroAsStdRound) {
  // round_half_away replaces std::round on the searches' hot path: it must give the same integer
  // everywhere, the halves and the doubles next to them included (a voxel one off moves a score).
  std::vector<double> v = {0.0,
                           -0.0,
                           0.5,
                           -0.5,
                           1.5,
                           -1.5,
                           2.5,
                           -2.5,
                           1e-300,
                           -1e-300,
                           std::nextafter(0.5, 0.0),
                           std::nextafter(-0.5, 0.0),
                           std::nextafter(0.5, 1.0),
                           std::nextafter(-0.5, -1.0),
                           std::nextafter(2.5, 0.0),
                           std::nextafter(-2.5, 0.0),
                           1073741823.5,
                           -1073741823.5};
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> wide(-1e6, 1e6), narrow(-3.0, 3.0);
  for (int i = 0; i < 100000; ++i) v.push_back(i % 2 ? wide(rng) : narrow(rng));
  for (int i = -2000; i <= 2000; ++i) v.push_back(0.25 * i);  // every quarter: halves on the way
  for (const double x : v)
    ASSERT_EQ(detail::round_half_away(x), static_cast<int>(std::round(x))) << std::hexfloat << x;
  // Far beyond any grid: clamped, finite and on the right side, never undefined.
  EXPECT_EQ(detail::round_half_away(1e300), 1 << 30);
  EXPECT_EQ(detail::round_half_away(-1e300), -(1 << 30));
}

}  // namespace
}  // namespace brainshift::constraints
