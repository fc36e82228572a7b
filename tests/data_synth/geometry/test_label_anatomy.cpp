// The label-anatomy builder (issue 18): a labelled ellipsoid (the analytic phantom rasterised,
// 2 mm voxels to keep it fast) must give the same kind of anatomy as the analytic phantom — hull
// on the brain surface, the labels' own tumour found, a voxel truth mesh of the brain's volume —
// defaults placed as documented, and bad inputs refused with one line naming the value.

#include "core/error.hpp"
#include "data_synth/geometry/label_anatomy.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace brainshift::data_synth {
namespace {

PhantomGeometry ellipsoid_phantom(bool with_tumour) {
  PhantomGeometry g;
  if (!with_tumour) g.tumour_radius = 1e-3;  // rasterises to no voxel at 2 mm
  return g;
}

imaging::LabelVolume labels_of(const PhantomGeometry& g) {
  PhantomImageOptions io;
  io.spacing = 2.0;
  return make_label_volume(g, io);
}

const LabelAnatomy& tumour_anatomy() {
  static const LabelAnatomy a =
      make_label_anatomy(labels_of(ellipsoid_phantom(true)), {}, "ellipsoid labels");
  return a;
}

TEST(LabelAnatomy, HullLiesOnTheEllipsoidAndTheLabelsTumourIsFound) {
  const PhantomGeometry g = ellipsoid_phantom(true);
  const LabelAnatomy& a = tumour_anatomy();
  const Ellipsoid brain = g.brain_ellipsoid();
  // Points of the upper ellipsoid (above the base cut): the hull's zero level within 1.5 mm —
  // the 2 mm voxels' staircase (±1 mm) plus the closing and smoothing of a convex shape (which
  // move a smooth surface by well under a voxel).
  for (double theta = 0.2; theta < 1.4; theta += 0.3)
    for (double phi = 0.0; phi < 2.0 * std::numbers::pi; phi += 0.7) {
      const Vector3d d(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi),
                       std::cos(theta));
      const Vector3d x = brain.centre + brain.semi_axes.cwiseProduct(d);
      EXPECT_NEAR(a.hull->value(x), 0.0, 1.5) << x.transpose();
      // The skull is the hull grown by the 2.5 mm gap: the convex brain needs no bridging, so the
      // same staircase tolerance.
      EXPECT_NEAR(a.skull->value(x), -2.5, 1.5) << x.transpose();
    }
  EXPECT_EQ(a.tumour_placement, Placement::FROM_LABELS);
  // Centroid and equivalent-sphere radius of the 12 mm tumour at 2 mm voxels: within a voxel.
  EXPECT_LT((a.tumour_centre - g.tumour_centre()).norm(), 1.0);
  EXPECT_NEAR(a.tumour_radius, g.tumour_radius, 1.0);
  // Brain volume (labels 1-3) against the analytic cut ellipsoid: 2 % (the staircase).
  EXPECT_NEAR(a.brain_volume_ml, analytic_volumes(g).brain_total / 1000.0,
              0.02 * analytic_volumes(g).brain_total / 1000.0);
}

TEST(LabelAnatomy, DefaultsPutTheCraniotomyOnTheUpperConvexityAndTheTumourBeneathIt) {
  const PhantomGeometry g = ellipsoid_phantom(false);
  const LabelAnatomy a = make_label_anatomy(labels_of(g), {}, "ellipsoid labels");
  EXPECT_EQ(a.craniotomy_placement, Placement::DEFAULT);
  EXPECT_EQ(a.tumour_placement, Placement::DEFAULT);
  // On the hull (Newton projection: 0.1 mm) and on the upper convexity: the normal is within 40°
  // of up (the default direction is up tilted 25° toward +R; the ellipsoid's normal there tilts
  // further, but not past 40°), on the right (+R) side.
  EXPECT_NEAR(a.hull->value(a.craniotomy_centre), 0.0, 0.1);
  EXPECT_GT(a.craniotomy_normal.z(), std::cos(40.0 * std::numbers::pi / 180.0))
      << a.craniotomy_normal.transpose();
  EXPECT_GT(a.craniotomy_centre.x(), g.centre.x());
  // Tumour: 30 mm beneath along the inward normal, radius 10 mm, written into the labels.
  EXPECT_NEAR((a.tumour_centre - a.craniotomy_centre).norm(), 30.0, 1e-9);
  EXPECT_DOUBLE_EQ(a.tumour_radius, 10.0);
  EXPECT_EQ(a.voxel_label(a.tumour_centre), imaging::TUMOUR);
  EXPECT_EQ(a.voxel_label(a.tumour_centre + 12.0 * Vector3d::UnitX()), imaging::BRAIN);
}

TEST(LabelAnatomy, GivenPlacementsAreUsedAndProjected) {
  const PhantomGeometry g = ellipsoid_phantom(false);
  LabelAnatomyOptions o;
  const Vector3d top = g.centre + Vector3d(0.0, 0.0, g.semi_axes.z());
  o.craniotomy = top + Vector3d(0.0, 0.0, 5.0);  // 5 mm above the surface: projected onto it
  o.tumour_centre = g.centre + Vector3d(-20.0, 10.0, 20.0);
  o.tumour_radius = 8.0;
  const LabelAnatomy a = make_label_anatomy(labels_of(g), o, "ellipsoid labels");
  EXPECT_EQ(a.craniotomy_placement, Placement::GIVEN);
  // Within the staircase tolerance of the top point.
  EXPECT_LT((a.craniotomy_centre - top).norm(), 1.5);
  EXPECT_EQ(a.tumour_placement, Placement::GIVEN);
  EXPECT_DOUBLE_EQ(a.tumour_radius, 8.0);
  EXPECT_EQ(a.voxel_label(*o.tumour_centre), imaging::TUMOUR);
}

TEST(LabelAnatomy, TruthMeshFillsTheBrainWithAFixedBase) {
  const PhantomGeometry g = ellipsoid_phantom(true);
  const LabelAnatomy& a = tumour_anatomy();
  PhantomMeshOptions o;
  o.cell_size = 6.0;
  const PhantomMesh m = make_label_mesh(a, o);
  double volume = 0.0;
  for (index_t t = 0; t < m.mesh.num_tets(); ++t) {
    // core::validate already refuses inverted elements; check positivity again here anyway.
    ASSERT_GT(m.mesh.signed_volume(t), 0.0);
    volume += m.mesh.signed_volume(t);
  }
  // Volume within 5 % of the analytic brain: snapped boundary, with the unsnapped stair corners.
  const double analytic = analytic_volumes(g).brain_total;
  EXPECT_NEAR(volume, analytic, 0.05 * analytic);
  // The fixed base: the flattened bottom (and the rim within 10 mm of it) and nothing higher.
  ASSERT_FALSE(m.base_nodes.empty());
  for (const index_t n : m.base_nodes)
    EXPECT_LE(m.mesh.nodes()(n, 2), g.base_level() + 10.0 + 1e-9);
  EXPECT_GT(m.surface_nodes.size(), 5 * m.base_nodes.size() / 10);
  // The tumour is in the mesh's materials.
  EXPECT_GT(std::count(m.tet_labels.begin(), m.tet_labels.end(), imaging::TUMOUR), 0);
  EXPECT_GT(std::count(m.tet_labels.begin(), m.tet_labels.end(), imaging::VENTRICLES), 0);
}

TEST(DistanceField, SphereValuesNormalsAndClosestPoints) {
  // φ = |x − c| − 30 sampled on 1 mm voxels: trilinear interpolation of a distance function is
  // exact to O(h²/R) ≈ 0.02 mm away from the centre; 0.05 mm allows for the float storage.
  imaging::ImageGeometry g;
  g.size = {81, 81, 81};
  g.origin = Vector3d(-40.0, -40.0, -40.0);
  imaging::VolumeF phi(g, 1, 0.0F);
  for (int k = 0; k < 81; ++k)
    for (int j = 0; j < 81; ++j)
      for (int i = 0; i < 81; ++i)
        phi.at(i, j, k) = float(g.index_to_world(Vector3d(i, j, k)).norm() - 30.0);
  const DistanceField f(std::move(phi));
  const Vector3d x(10.3, -7.7, 25.1);
  EXPECT_NEAR(f.value(x), x.norm() - 30.0, 0.05);
  EXPECT_LT((f.normal(x) - x.normalized()).norm(), 0.01);  // gradient of a smooth field: 1 %
  EXPECT_LT((f.closest_point(x) - 30.0 * x.normalized()).norm(), 0.05);
  EXPECT_LT((f.closest_point(x, -2.5) - 27.5 * x.normalized()).norm(), 0.05);
  // Outside the grid the field keeps growing (value at the nearest grid point + the distance).
  EXPECT_GT(f.value(Vector3d(0.0, 0.0, 100.0)), f.value(Vector3d(0.0, 0.0, 40.0)) + 59.0);
}

/// The error message of `f` (empty when it does not throw).
template <typename F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(LabelAnatomy, BadInputsAreOneLineErrorsNamingTheValue) {
  const PhantomGeometry g = ellipsoid_phantom(false);
  const imaging::LabelVolume labels = labels_of(g);
  imaging::LabelVolume empty = labels;
  std::fill(empty.data.begin(), empty.data.end(), 0);
  std::string e = error_of([&] { (void)make_label_anatomy(empty, {}, "empty.nii.gz"); });
  EXPECT_NE(e.find("empty.nii.gz has no brain"), std::string::npos) << e;
  EXPECT_EQ(e.find('\n'), std::string::npos) << e;

  imaging::LabelVolume odd = labels;
  odd.data[odd.data.size() / 2] = 7;
  e = error_of([&] { (void)make_label_anatomy(odd, {}, "odd.nii.gz"); });
  EXPECT_NE(e.find("label 7"), std::string::npos) << e;

  LabelAnatomyOptions o;
  o.tumour_centre = Vector3d(500.0, 0.0, 0.0);
  e = error_of([&] { (void)make_label_anatomy(labels, o, "l.nii.gz"); });
  EXPECT_NE(e.find("tumour centre (500, 0, 0) mm is outside the brain of l.nii.gz"),
            std::string::npos)
      << e;

  o = {};
  o.tumour_centre = g.centre;
  o.tumour_radius = -2.0;
  e = error_of([&] { (void)make_label_anatomy(labels, o, "l.nii.gz"); });
  EXPECT_NE(e.find("tumour radius -2 mm"), std::string::npos) << e;

  o = {};
  o.craniotomy = Vector3d(0.0, 0.0, 300.0);
  e = error_of([&] { (void)make_label_anatomy(labels, o, "l.nii.gz"); });
  EXPECT_NE(e.find("craniotomy (0, 0, 300) mm is outside the brain of l.nii.gz"), std::string::npos)
      << e;
}

}  // namespace
}  // namespace brainshift::data_synth
