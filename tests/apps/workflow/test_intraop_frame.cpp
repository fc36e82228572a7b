// How far the answer's rigid part moves the model's fixed base (apps/workflow/intraop_frame.hpp),
// against closed forms: a translation moves every fixed node by its length, a rotation by θ about
// an axis moves a node at distance ρ from it by 2ρ sin(θ/2). And when the report says so.
#include "tests/constraints/registration/sag_scene.hpp"

#include "apps/workflow/intraop_frame.hpp"
#include "constraints/registration/start/global_start.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace brainshift::workflow {
namespace {

using constraints::RegistrationResult;

/// A result whose rigid part takes model points to the intra-operative frame by `intraop_from`.
RegistrationResult with_pose(const Eigen::Isometry3d& intraop_from) {
  RegistrationResult r;
  r.start.transform = intraop_from.inverse();  // model_from_intraop
  return r;
}

TEST(FixedBaseMotion, ATranslationMovesEveryFixedNodeByItsLength) {
  const constraints::Scene s;
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.translation() = Vector3d(3, 4, 12);  // 13 mm
  const FixedBaseMotion m = fixed_base_motion(with_pose(t), *s.model);
  ASSERT_GT(m.nodes, 10);  // the ellipsoid's base below z = −22 mm
  // Round-off of a 3-vector difference: 1e-12 mm.
  EXPECT_NEAR(m.mean_mm, 13.0, 1e-12);
  EXPECT_NEAR(m.max_mm, 13.0, 1e-12);
  EXPECT_EQ(fixed_base_motion(with_pose(Eigen::Isometry3d::Identity()), *s.model).max_mm, 0.0);
}

TEST(FixedBaseMotion, ARotationMovesEachFixedNodeByTheChordOfItsCircle) {
  const constraints::Scene s;
  // 6° about the vertical axis through (5, −3, 0): a node at distance ρ from the axis moves
  // 2ρ sin(3°).
  const double theta = 6.0 * std::numbers::pi / 180.0;
  const Vector3d c(5, -3, 0);
  Eigen::Isometry3d rot = Eigen::Isometry3d::Identity();
  rot.linear() = Eigen::AngleAxisd(theta, Vector3d::UnitZ()).toRotationMatrix();
  rot.translation() = c - rot.linear() * c;
  double sum = 0, mx = 0;
  index_t n = 0;
  for (index_t i = 0; i < s.mesh.num_nodes(); ++i) {
    if (!(s.mesh.nodes()(i, 2) < -22)) continue;  // the scene's fixed nodes
    const Vector3d X = s.mesh.nodes().row(i).transpose();
    const double rho = std::hypot(X.x() - c.x(), X.y() - c.y());
    const double chord = 2.0 * rho * std::sin(theta / 2.0);
    sum += chord;
    mx = std::max(mx, chord);
    ++n;
  }
  const FixedBaseMotion m = fixed_base_motion(with_pose(rot), *s.model);
  ASSERT_EQ(m.nodes, n);
  // The chords are ≈ 4 mm; the transform's composition (T⁻¹ of a rotation about c) and the sum
  // over the nodes round at 1e-14 relative: 1e-9 mm is far above that, far below any wrong node.
  EXPECT_NEAR(m.mean_mm, sum / double(n), 1e-9);
  EXPECT_NEAR(m.max_mm, mx, 1e-9);
}

TEST(FixedBaseMotion, TheNoteOnlyWhenASearchedPoseMovesTheBaseBeyondTheNavigationsAccuracy) {
  constraints::RegistrationOptions o;
  // Without a stated accuracy the yardstick is RESECT's measured one; with one, that one.
  EXPECT_EQ(navigation_yardstick_mm(o), constraints::kResectNavigationAccuracyMm);
  o.global_start.navigation_accuracy_mm = 4.0;
  EXPECT_EQ(navigation_yardstick_mm(o), 4.0);
  const FixedBaseMotion far{15.05, 21.26, 243}, near{3.2, 4.1, 243};
  const std::string note = fixed_base_note(far, /*pose_given=*/false, 6.6);
  EXPECT_NE(note.find("15.1 mm on average (max 21.3 mm)"), std::string::npos) << note;
  EXPECT_NE(note.find("6.6 mm RMS"), std::string::npos) << note;
  EXPECT_NE(note.find("--pre-dura"), std::string::npos) << note;
  EXPECT_TRUE(fixed_base_note(far, /*pose_given=*/true, 6.6).empty());  // measured apart
  EXPECT_TRUE(fixed_base_note(near, /*pose_given=*/false, 6.6).empty());
  EXPECT_TRUE(fixed_base_note(far, /*pose_given=*/false, 20.0).empty());
}

}  // namespace
}  // namespace brainshift::workflow
