// Registration loop tests built from an analytic deformation (not from the registration model):
// the truth is a smooth sag field applied to the skeleton; intra-operative vessel points are
// sampled from the deformed skeleton with 0.3 mm noise.
#include "tests/constraints/registration/sag_scene.hpp"
#include "tolerance.hpp"

#include "constraints/registration/pairing/pairing.hpp"
#include "constraints/registration/registration.hpp"
#include "core/mesh/boundary.hpp"
#include "data_synth/geometry/structured_mesh.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

namespace brainshift::constraints {
namespace {

/// The loop itself: the noise model's choice between the loop's deformation and the start
/// (NoiseOptions::enabled, on by default) is off here. On this scene's six long branches of white
/// 0.3 mm noise the held-out branches cannot show the deformation's gain and the default keeps
/// the start (TheDefaultKeepsTheStartWhereHeldOutBranchesCannotShowTheGain below).
RegistrationOptions options() {
  RegistrationOptions o;
  o.start = RigidStart::IDENTITY;  // the loop from the tracked frame (the scene's own frame)
  o.max_iterations = 60;
  o.noise.enabled = false;
  return o;
}

TEST(Registration, NoVesselPointsMeansNoMotionAndAReportThatSaysWhy) {
  Scene s;
  const RegistrationResult r = register_model(*s.model, IntraopData{}, options());
  EXPECT_EQ(r.stop, RegistrationStop::NO_DATA);
  EXPECT_EQ(r.displacement.cwiseAbs().maxCoeff(), 0.0);
  EXPECT_NE(r.stop_reason.find("no intra-operative vessel points"), std::string::npos)
      << r.stop_reason;
}

TEST(Registration, RecoversASmoothSagFromNoisyVesselPoints) {
  Scene s;
  IntraopData d;
  d.vessel_points = sample_deformed(s.skeleton, 0.3, 1);
  const auto before = s.landmark_error(s.mesh.nodes());
  const RegistrationResult r = register_model(*s.model, d, options());
  ASSERT_TRUE(r.positions.allFinite());
  const auto after = s.landmark_error(r.positions);
  std::cout << "[ registration ] landmark error before " << before.first << " mm (max "
            << before.second << "), after " << after.first << " mm (max " << after.second << "), "
            << r.iterations << " iterations, " << r.seconds.total << " s, stop: " << r.stop_reason
            << "\n";
  EXPECT_TRUE(r.converged) << r.stop_reason;
  EXPECT_GT(before.first, 3.0);  // the case has a real shift
  EXPECT_LE(after.first, 0.5);   // issue 4: landmark error ≤ 0.5 mm
}

TEST(Registration, TheDefaultKeepsTheStartWhereHeldOutBranchesCannotShowTheGain) {
  // The same data with the default options: the paired test (z = 2) on the six held-out
  // branches does not find the loop's deformation significantly better than the start's rigid +
  // bulk state, so the answer is that state, bit for bit (start_only), and it still removes most of
  // the shift. The loop alone reaches ≤ 0.5 mm here (above): this is the default's known cost where
  // the vessels are few and long (docs/history/BENCHMARKS_NOTEBOOK.md, "Never worse than rigid,
  // v7").
  Scene s;
  IntraopData d;
  d.vessel_points = sample_deformed(s.skeleton, 0.3, 1);
  RegistrationOptions o;
  o.start = RigidStart::IDENTITY;  // the loop from the tracked frame (the scene's own frame)
  o.max_iterations = 60;
  const RegistrationResult r = register_model(*s.model, d, o);
  ASSERT_TRUE(r.converged) << r.stop_reason;
  ASSERT_TRUE(r.noise.valid && r.noise.keep_start) << r.noise.message;
  EXPECT_EQ(r.noise.blocks, 6) << r.noise.message;
  const RegistrationResult start = start_only(*s.model, d, o);
  EXPECT_EQ((r.positions - start.positions).cwiseAbs().maxCoeff(), 0.0);
  const auto before = s.landmark_error(s.mesh.nodes());
  const auto after = s.landmark_error(r.positions);
  // Less than a third of the shift is left (measured 1.17 of 4.09 mm).
  EXPECT_LT(after.first, before.first / 3) << r.noise.message;
}

TEST(Registration, ThirtyPercentOutliersAreFiltered) {
  Scene s;
  IntraopData d;
  const MatrixX3d clean = sample_deformed(s.skeleton, 0.3, 2);
  const Eigen::Index n_out = clean.rows() * 3 / 7;  // 30 % of the total
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> ux(-35, 35), uz(-5, 25);
  d.vessel_points.resize(clean.rows() + n_out, 3);
  d.vessel_points.topRows(clean.rows()) = clean;
  for (Eigen::Index i = 0; i < n_out; ++i)
    d.vessel_points.row(clean.rows() + i) << ux(rng), ux(rng), uz(rng);
  const RegistrationResult r = register_model(*s.model, d, options());
  ASSERT_TRUE(r.positions.allFinite());
  const auto after = s.landmark_error(r.positions);
  std::cout << "[ registration, 30 % outliers ] landmark error " << after.first << " mm (max "
            << after.second << ")\n";
  EXPECT_LE(after.first, 1.0);  // issue 4: error stays ≤ 1 mm
}

TEST(Registration, WarmStartFromAPreviousResultConvergesInFewerIterations) {
  // Replay: frame 1 at 80 % of the shift, frame 2 at 100 % with new noise. Frame 2 from the
  // rest shape (cold) against frame 2 from frame 1's result (warm).
  Scene s;
  IntraopData frame1, frame2;
  frame1.vessel_points = sample_deformed(s.skeleton, 0.3, 4, 0.8);
  frame2.vessel_points = sample_deformed(s.skeleton, 0.3, 5, 1.0);
  const RegistrationResult first = register_model(*s.model, frame1, options());
  ASSERT_TRUE(first.converged) << first.stop_reason;
  const RegistrationResult cold = register_model(*s.model, frame2, options());
  const RegistrationResult warm = register_model(*s.model, frame2, options(), &first);
  ASSERT_TRUE(cold.converged) << cold.stop_reason;
  ASSERT_TRUE(warm.converged) << warm.stop_reason;
  std::cout << "[ registration, replay ] frame 2 cold " << cold.iterations << " iterations, warm "
            << warm.iterations << "\n";
  EXPECT_LT(warm.iterations, cold.iterations);
  // Both reach the same answer (the fixed point does not depend on the start) to within the
  // 0.01 mm increment tolerance accumulated over the tail of the iteration.
  EXPECT_LT((warm.positions - cold.positions).rowwise().norm().maxCoeff(), 0.1);
}

/// One straight vessel along x at z = 10 mm, points every 2.5 mm.
core::Skeleton straight_vessel() {
  core::Skeleton s;
  const int n = 17;
  s.points.resize(n, 3);
  for (int k = 0; k < n; ++k) s.points.row(k) << -20.0 + 2.5 * k, 0.0, 10.0;
  for (int k = 0; k + 1 < n; ++k) s.segments.push_back({k, k + 1});
  return s;
}

TEST(Registration, ASlidingPointMovesAlongItsVesselFreely) {
  // The vessel is seen 4 mm further along its own axis and 3 mm lower. Sliding constraints act
  // only normal to the vessel: the model must follow the 3 mm drop and must not be dragged the
  // 4 mm along the axis (a point-to-point pairing would drag it).
  Scene s(straight_vessel());
  IntraopData d;
  d.vessel_points.resize(s.skeleton.points.rows() - 2, 3);
  for (Eigen::Index k = 0; k < d.vessel_points.rows(); ++k)
    d.vessel_points.row(k) = s.skeleton.points.row(k + 1) + Eigen::RowVector3d(4.0, 0.0, -3.0);
  RegistrationOptions o = options();
  o.min_vessel_pairs = 10;  // 15 exact points on one clean vessel: enough for this question
  const RegistrationResult r = register_model(*s.model, d, o);
  ASSERT_TRUE(r.converged) << r.stop_reason;
  const MatrixX3d p = s.model->skeleton_mapping().apply(r.positions);
  const Eigen::Index mid = s.skeleton.points.rows() / 2;
  const Vector3d u = (p.row(mid) - s.skeleton.points.row(mid)).transpose();
  // Normal part met to within the compliance of the soft rows (ratio 0.2 → ≤ 10 % of 3 mm for
  // a coherent shift of many rows; measured 2.9 mm).
  EXPECT_NEAR(u.z(), -3.0, 0.3);
  // Tangential part: only what the elastic coupling of the drop gives, far below the 4 mm seen.
  EXPECT_LT(std::abs(u.x()), 0.5) << u.transpose();
}

TEST(Registration, RigidStartRecoversATrackingOffset) {
  // No deformation, only a tracking error of 6 mm / 6°: the rigid start must absorb it and the
  // elastic loop then has (almost) nothing left to do.
  Scene s;
  const Eigen::Isometry3d offset =
      Eigen::Translation3d(3.0, -4.0, 3.0) *
      Eigen::AngleAxisd(6.0 * std::numbers::pi / 180.0, Vector3d(1, 2, 2).normalized());
  IntraopData d;
  std::mt19937 rng(7);
  std::normal_distribution<double> g(0.0, 0.3);
  d.vessel_points.resize(s.skeleton.points.rows(), 3);
  for (Eigen::Index i = 0; i < d.vessel_points.rows(); ++i)
    d.vessel_points.row(i) =
        (offset * Vector3d(s.skeleton.points.row(i).transpose()) + Vector3d(g(rng), g(rng), g(rng)))
            .transpose();
  RegistrationOptions o = options();
  o.start = RigidStart::RIGID;
  const RegistrationResult r = register_model(*s.model, d, o);
  ASSERT_TRUE(r.start.converged) << r.start.stop_reason;
  const Eigen::Isometry3d err = r.start.transform * offset;  // identity when exact
  // Issue 4: ≤ 0.5 mm / 0.5° (measured ≈ 0.05 mm / 0.05° on this case).
  EXPECT_LT(err.translation().norm(), 0.5);
  EXPECT_LT(Eigen::AngleAxisd(err.linear()).angle() * 180.0 / std::numbers::pi, 0.5);
  // The residual elastic correction is of the order of the noise.
  EXPECT_LT(r.displacement.rowwise().norm().maxCoeff(), 1.0);
  EXPECT_GT(r.seconds.rigid, 0.0);
}

TEST(Registration, FootprintPushesTheSurfaceAndTheDuraHoldsItElsewhere) {
  // The probe presses a plane 3 mm into the top of the ellipsoid (top at z = 30 mm). Footprint
  // rows are unilateral: no surface point may stay above the plane. Outside a 25 mm craniotomy
  // the dura (bilateral sliding) keeps the surface on its rest shape.
  Scene s;
  IntraopData d;
  std::vector<Vector3d> pts;
  for (double x = -10; x <= 10; x += 10)  // sampled every 10 mm, as from B-mode
    for (double y = -10; y <= 10; y += 10) pts.emplace_back(x, y, 27.0);
  d.footprint_points.resize(static_cast<Eigen::Index>(pts.size()), 3);
  d.footprint_normals.resize(d.footprint_points.rows(), 3);
  for (std::size_t i = 0; i < pts.size(); ++i) {
    d.footprint_points.row(static_cast<Eigen::Index>(i)) = pts[i].transpose();
    d.footprint_normals.row(static_cast<Eigen::Index>(i)) << 0, 0, -1;  // into the tissue
  }
  RegistrationOptions o = options();
  o.use_vessels = false;
  o.footprint_filter.max_per_tet = 0;
  o.dura.mode = DuraOptions::Mode::SLIDING;
  o.dura.craniotomy_centre = Vector3d(0, 0, 30);
  o.dura.craniotomy_radius_mm = 25.0;
  const RegistrationResult r = register_model(*s.model, d, o);
  ASSERT_TRUE(r.converged) << r.stop_reason;
  EXPECT_GT(r.rows_by_set[static_cast<std::size_t>(ConstraintSet::FOOTPRINT)], 0);
  EXPECT_GT(r.rows_by_set[static_cast<std::size_t>(ConstraintSet::DURA)], 0);
  const MatrixX3d surf = s.model->surface_mapping().apply(r.positions);
  const auto& rest = s.model->surface().vertices;
  // The surface point under each footprint point (closest on the deformed surface).
  const FeatureIndex deformed = FeatureIndex::triangles(surf, s.model->surface().triangles);
  double highest_under_probe = -1e9, worst_dura = 0;
  for (Eigen::Index i = 0; i < d.footprint_points.rows(); ++i)
    highest_under_probe =
        std::max(highest_under_probe,
                 deformed.nearest(d.footprint_points.row(i).transpose(), 20.0)->closest.z());
  for (Eigen::Index v = 0; v < rest.rows(); ++v) {
    const Vector3d X = rest.row(v).transpose();
    if ((X - o.dura.craniotomy_centre).norm() >= 25.0) {
      // Distance of the moved vertex to the rest surface: its ellipsoid implicit value, scaled to
      // mm.
      const Vector3d p = surf.row(v).transpose();
      const double f = std::sqrt(p.x() * p.x() / 1600 + p.y() * p.y() / 1225 + p.z() * p.z() / 900);
      worst_dura =
          std::max(worst_dura, std::abs(f - std::sqrt(X.x() * X.x() / 1600 + X.y() * X.y() / 1225 +
                                                      X.z() * X.z() / 900)) *
                                   30.0);
    }
  }
  // Unilateral footprint rows are hard: the surface under each probe point is at or below
  // z = 27 mm, up to the PGS tolerance and the 0.01 mm increment tolerance of the last step
  // (vertices between the probe points are not constrained and may bulge slightly).
  EXPECT_LE(highest_under_probe, 27.0 + 0.05);
  EXPECT_GT(highest_under_probe, 27.0 - 0.5);  // and it is in contact, not pushed away
  // Dura: vertices outside the craniotomy slide on the rest surface (faceted: its facets lie up
  // to ≈ 1 mm inside the analytic ellipsoid on this 7 mm mesh, hence the bound).
  EXPECT_LT(worst_dura, 1.5);
}

}  // namespace
}  // namespace brainshift::constraints
