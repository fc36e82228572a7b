#include "expect_error.hpp"
#include "random_rotation.hpp"
#include "tolerance.hpp"

#include "data_synth/geometry/brain_phantom.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <random>

namespace brainshift::data_synth {
namespace {

using imaging::Label;

/// Voxel volumes per label, mm³.
std::array<double, 4> label_volumes(const imaging::LabelVolume& v) {
  std::array<double, 4> out{};
  const double voxel = v.geometry.spacing.prod();
  for (const auto l : v.data) out[l] += voxel;
  return out;
}

Label label_of_voxel_at(const imaging::LabelVolume& v, const Vector3d& p) {
  const Vector3d ijk = v.geometry.world_to_index(p).array().round();
  EXPECT_TRUE(v.geometry.contains_index(int(ijk.x()), int(ijk.y()), int(ijk.z())));
  return Label(v.at(int(ijk.x()), int(ijk.y()), int(ijk.z())));
}

TEST(Ellipsoid, ClosestPointIsOnTheSurfaceAlongTheNormal) {
  const Ellipsoid e{{3, -2, 7}, {70, 85, 60}};
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> d(-120, 120);
  for (int trial = 0; trial < 200; ++trial) {
    const Vector3d x = e.centre + Vector3d(d(rng), d(rng), d(rng));
    const Vector3d q = e.closest_point(x);
    SCOPED_TRACE(::testing::Message() << "x " << x.transpose() << " q " << q.transpose());
    // On the surface to rounding; x − q parallel to the normal (the optimality condition).
    EXPECT_NEAR(e.level(q), 1.0, 1e-10);
    const Vector3d r = x - q;
    if (r.norm() > 1e-6) {
      EXPECT_GT(std::abs(r.normalized().dot(e.normal(q))), 1 - 1e-9);
    }
  }
}

class PhantomLabels : public ::testing::TestWithParam<bool> {};

TEST_P(PhantomLabels, VoxelVolumesMatchTheAnalyticVolumesAndWorldPointsHitTheirLabel) {
  const bool rotated = GetParam();
  SCOPED_TRACE(rotated ? "rotated image axes" : "identity image axes");
  const PhantomGeometry g;
  PhantomImageOptions o;
  std::mt19937 rng(42);
  if (rotated) o.direction = tests::random_rotation(rng);
  const imaging::LabelVolume v = make_label_volume(g, o);
  EXPECT_TRUE(v.geometry.direction.isApprox(o.direction));
  EXPECT_EQ(v.geometry.spacing, Vector3d::Ones());

  const auto vox = label_volumes(v);
  const PhantomVolumes a = analytic_volumes(g);
  // 1 mm voxels: the boundary error averages out over a surface of area S to ≪ S·0.5 mm;
  // measured ≈ 0.05 % (brain), 0.3 % (tumour), 1 % (thin ventricles). Bounds leave ~3× margin.
  EXPECT_TRUE(tests::near(vox[1] + vox[2] + vox[3], a.brain_total, 0, 2e-3));
  EXPECT_TRUE(tests::near(vox[2], a.tumour, 0, 1e-2));
  EXPECT_TRUE(tests::near(vox[3], a.ventricles, 0, 3e-2));
  EXPECT_TRUE(tests::near(vox[1], a.brain_total - a.tumour - a.ventricles, 0, 3e-3));

  EXPECT_EQ(label_of_voxel_at(v, g.tumour_centre()), imaging::TUMOUR);
  EXPECT_EQ(label_of_voxel_at(v, g.ventricle(0).centre), imaging::VENTRICLES);
  EXPECT_EQ(label_of_voxel_at(v, g.ventricle(1).centre), imaging::VENTRICLES);
  const Vector3d up = (g.craniotomy_centre_on_brain() - g.centre).normalized();
  EXPECT_EQ(label_of_voxel_at(v, g.craniotomy_centre_on_brain() - 3.0 * up), imaging::BRAIN);
  EXPECT_EQ(label_of_voxel_at(v, g.craniotomy_centre_on_brain() + 2.0 * up), imaging::BACKGROUND);
  EXPECT_EQ(label_of_voxel_at(v, Vector3d(g.centre.x(), g.centre.y(), g.base_level() - 2)),
            imaging::BACKGROUND);
  // The grid covers the skull: every corner voxel is background and lies outside the skull.
  for (int c = 0; c < 8; ++c) {
    const Eigen::Vector3i ijk((c & 1) * (v.geometry.size[0] - 1),
                              ((c >> 1) & 1) * (v.geometry.size[1] - 1),
                              ((c >> 2) & 1) * (v.geometry.size[2] - 1));
    EXPECT_EQ(v.at(ijk.x(), ijk.y(), ijk.z()), imaging::BACKGROUND);
    EXPECT_GT(g.skull().level(v.geometry.index_to_world(ijk.cast<double>())), 1.0);
  }
  RecordProperty("brain_volume_relative_error",
                 std::to_string((vox[1] + vox[2] + vox[3]) / a.brain_total - 1));
  RecordProperty("tumour_volume_relative_error", std::to_string(vox[2] / a.tumour - 1));
  RecordProperty("ventricle_volume_relative_error", std::to_string(vox[3] / a.ventricles - 1));
}

INSTANTIATE_TEST_SUITE_P(BrainPhantom, PhantomLabels, ::testing::Bool());

TEST(BrainPhantom, CraniotomyCentresLieOnBrainAndSkull) {
  const PhantomGeometry g;
  // Ray-ellipsoid intersection is closed form: exact to rounding.
  EXPECT_NEAR(g.brain_ellipsoid().level(g.craniotomy_centre_on_brain()), 1.0, 1e-12);
  EXPECT_NEAR(g.skull().level(g.craniotomy_centre_on_skull()), 1.0, 1e-12);
  EXPECT_GT(g.craniotomy_centre_on_brain().z(), g.centre.z());  // on the top surface
}

TEST(BrainPhantom, RejectsInvalidParameters) {
  PhantomGeometry g;
  g.tumour_offset = {0, 0, 200};
  tests::expect_error([&] { (void)make_label_volume(g); }, {"tumour", "outside"});
  g = {};
  g.skull_gap = -1;
  tests::expect_error([&] { (void)make_label_volume(g); }, {"skull_gap"});
  PhantomImageOptions o;
  o.direction(0, 0) = 2;
  tests::expect_error([&] { (void)make_label_volume({}, o); }, {"direction"});
}

}  // namespace
}  // namespace brainshift::data_synth
