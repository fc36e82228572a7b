#include "expect_error.hpp"
#include "random_rotation.hpp"

#include "imaging/footprint/footprint.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <iostream>
#include <limits>
#include <random>
#include <string>

namespace brainshift::imaging {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kBandHalfWidth = 0.75;  // the drawn contact band is 1.5 mm thick
constexpr double kDark = 0.05;           // mean echo above the surface (saline, gel)
constexpr double kBand = 1.0;            // mean echo of the contact band
constexpr double kTissue = 0.3;          // mean echo of the parenchyma below

/// A known contact surface under the probe: signed distance (> 0 in the tissue, mm) and the
/// unit normal into the tissue at the nearest surface point.
struct Surface {
  std::string name;
  std::function<double(const Vector3d&)> signed_distance;
  std::function<Vector3d(const Vector3d&)> normal;
};

/// The probe of every test: oblique axis and a lateral direction that is not orthogonal to it
/// (extract_footprint makes it so).
ProbePose test_probe() {
  ProbePose pose;
  pose.face_centre = Vector3d(10.0, -20.0, 60.0);
  pose.axis = Vector3d(0.3, -0.2, -1.0).normalized();
  pose.lateral = Vector3d(1.0, 0.2, 0.1);
  return pose;
}

/// The probe frame as extract_footprint() builds it (footprint.hpp).
void probe_frame(const ProbePose& pose, Vector3d& u, Vector3d& v, Vector3d& w) {
  w = pose.axis.normalized();
  u = (*pose.lateral - pose.lateral->dot(w) * w).normalized();
  v = w.cross(u);
}

/// A plane through the point at `depth` under the face centre, tilted from the face plane by
/// `tilt_u_deg` towards the lateral direction and `tilt_v_deg` towards the elevation.
Surface tilted_plane(double depth, double tilt_u_deg, double tilt_v_deg) {
  const ProbePose pose = test_probe();
  Vector3d u, v, w;
  probe_frame(pose, u, v, w);
  const Vector3d n =
      (w + std::tan(tilt_u_deg * kPi / 180.0) * u + std::tan(tilt_v_deg * kPi / 180.0) * v)
          .normalized();
  const Vector3d q = pose.face_centre + depth * w;
  return {"tilted plane", [n, q](const Vector3d& p) { return n.dot(p - q); },
          [n](const Vector3d&) { return n; }};
}

/// A sphere (the brain, convex towards the probe) of radius R whose top is `depth` under the
/// face centre.
Surface sphere_cap(double depth, double radius) {
  const ProbePose pose = test_probe();
  const Vector3d c = pose.face_centre + (depth + radius) * pose.axis.normalized();
  return {"sphere cap", [c, radius](const Vector3d& p) { return radius - (p - c).norm(); },
          [c](const Vector3d& p) { return Vector3d((c - p).normalized()); }};
}

/// Overlap length of [a, b] and [lo, hi].
double overlap(double a, double b, double lo, double hi) {
  return std::max(0.0, std::min(b, hi) - std::max(a, lo));
}

/// A B-mode volume over the probe's field of view: a rotated grid with anisotropic voxels, dark
/// above the surface, a 1.5 mm bright band centred on it, tissue below; partial-volume
/// antialiasing across the voxel's extent along the normal, and fully developed speckle
/// (Rayleigh amplitude, std/mean ≈ 0.52) on every voxel.
VolumeF draw_bmode(const Surface& surface, unsigned seed, double speckle = 1.0) {
  std::mt19937 rng(seed);
  const ProbePose pose = test_probe();
  Vector3d u, v, w;
  probe_frame(pose, u, v, w);
  ImageGeometry g;
  g.direction = tests::random_rotation(rng);
  g.spacing = Vector3d(0.7, 0.6, 0.8);
  // Index bounding box of the probe-frame box lateral ±23, elevation ±18, depth −3…29 mm.
  Vector3d lo = Vector3d::Constant(1e300);
  Vector3d hi = -lo;
  for (int corner = 0; corner < 8; ++corner) {
    const Vector3d p = pose.face_centre + ((corner & 1) ? 23.0 : -23.0) * u +
                       ((corner & 2) ? 18.0 : -18.0) * v + ((corner & 4) ? 29.0 : -3.0) * w;
    const Vector3d ijk = g.world_to_index(p);
    lo = lo.cwiseMin(ijk);
    hi = hi.cwiseMax(ijk);
  }
  g.origin = g.index_to_world(lo.array().floor().matrix());
  for (int a = 0; a < 3; ++a) g.size[a] = int(std::ceil(hi[a] - std::floor(lo[a]))) + 1;
  VolumeF image(g);
  std::normal_distribution<double> normal;
  constexpr double h = 0.7;  // voxel extent along the normal used for the antialiasing, mm
  for (int k = 0; k < g.size[2]; ++k)
    for (int j = 0; j < g.size[1]; ++j)
      for (int i = 0; i < g.size[0]; ++i) {
        const double s = surface.signed_distance(g.index_to_world(Vector3d(i, j, k)));
        const double a = s - 0.5 * h;
        const double b = s + 0.5 * h;
        const double band = overlap(a, b, -kBandHalfWidth, kBandHalfWidth) / h;
        const double tissue = overlap(a, b, kBandHalfWidth, 1e300) / h;
        const double mean = kDark * (1.0 - band - tissue) + kBand * band + kTissue * tissue;
        const double re = normal(rng);
        const double im = normal(rng);
        const double rayleigh = std::sqrt(0.5 * (re * re + im * im)) / 0.886;  // mean 1
        image.at(i, j, k) = float(mean * (1.0 - speckle + speckle * rayleigh));
      }
  return image;
}

/// The options of the accuracy tests: a 40 × 30 mm aperture (a matrix probe or a short sweep,
/// so that the footprint has rows in elevation too); other settings are the defaults.
FootprintOptions wide_aperture() {
  FootprintOptions o;
  o.aperture_width_mm = 40.0;
  o.aperture_elevation_mm = 30.0;
  return o;
}

struct Accuracy {
  double max_distance = 0.0;   // |signed distance| of the points to the true surface, mm
  double max_angle_deg = 0.0;  // angle between the normals and the true normals
};

Accuracy measure(const FootprintResult& r, const Surface& surface) {
  Accuracy a;
  for (Eigen::Index p = 0; p < r.points.rows(); ++p) {
    const Vector3d x = r.points.row(p).transpose();
    const Vector3d n = r.normals.row(p).transpose();
    a.max_distance = std::max(a.max_distance, std::abs(surface.signed_distance(x)));
    const double c = std::clamp(n.dot(surface.normal(x)), -1.0, 1.0);
    a.max_angle_deg = std::max(a.max_angle_deg, std::acos(c) * 180.0 / kPi);
  }
  return a;
}

class FootprintOnSurface : public ::testing::TestWithParam<int> {
 protected:
  [[nodiscard]] Surface surface() const {
    return GetParam() == 0 ? tilted_plane(/*depth=*/10.0, /*tilt_u_deg=*/18.0, /*tilt_v_deg=*/8.0)
                           : sphere_cap(/*depth=*/8.0, /*radius=*/40.0);
  }
};

// Tolerances (the brief's): points within 0.5 mm of the true surface (a third of the band, below
// the voxel size), normals within 5°. Each point is a quadric fit over the ≈ 700 rays of a 7.5 mm
// disc, so speckle mostly averages out; what remains is the blur of the band against the
// brighter tissue below (≈ +0.25 mm, deeper) and, at the patch's edge, a one-sided disc.
constexpr double kMaxDistanceMm = 0.5;
constexpr double kMaxAngleDeg = 5.0;

TEST_P(FootprintOnSurface, PointsLieOnTheSurfaceWithItsNormalsEvery10mm) {
  const Surface s = surface();
  SCOPED_TRACE(s.name);
  const VolumeF image = draw_bmode(s, /*seed=*/7u + unsigned(GetParam()));
  const FootprintResult r = extract_footprint(image, test_probe(), wide_aperture());
  ASSERT_EQ(r.status, FootprintStatus::OK) << r.message;
  // 40 × 30 mm at 10 mm: a lattice of 4–5 × 3–4 nodes over the patch.
  EXPECT_GE(r.points.rows(), 9);
  EXPECT_EQ(r.points.rows(), r.normals.rows());
  EXPECT_TRUE(r.points.allFinite());
  EXPECT_TRUE(r.normals.allFinite());
  const Accuracy a = measure(r, s);
  std::cout << "[ measured ] " << s.name << ": " << r.points.rows() << " points, max distance "
            << a.max_distance << " mm, max normal angle " << a.max_angle_deg << " deg, threshold "
            << r.threshold << " (" << r.threshold_rule << "), contrast " << r.contrast << "\n";
  EXPECT_LE(a.max_distance, kMaxDistanceMm);
  EXPECT_LE(a.max_angle_deg, kMaxAngleDeg);

  // Normals are unit and point into the tissue, along the probe axis.
  const Vector3d axis = test_probe().axis.normalized();
  for (Eigen::Index p = 0; p < r.points.rows(); ++p) {
    EXPECT_NEAR(r.normals.row(p).norm(), 1.0, 1e-12);
    EXPECT_GT(r.normals.row(p).dot(axis.transpose()), 0.0);
  }

  // Spacing: lattice neighbours are 10 mm apart across the face (exact, up to rounding) and
  // 10 mm / cos(slope) ≤ 10.6 mm in 3-D (slopes here ≤ 19.5°, the plane's combined tilt).
  Vector3d u, v, w;
  probe_frame(test_probe(), u, v, w);
  for (Eigen::Index p = 0; p < r.points.rows(); ++p) {
    double nearest_face = 1e300;
    double nearest_3d = 1e300;
    for (Eigen::Index q = 0; q < r.points.rows(); ++q) {
      if (q == p) continue;
      const Vector3d d = (r.points.row(q) - r.points.row(p)).transpose();
      nearest_face = std::min(nearest_face, (d - d.dot(w) * w).norm());
      nearest_3d = std::min(nearest_3d, d.norm());
    }
    EXPECT_NEAR(nearest_face, 10.0, 1e-9);
    EXPECT_GE(nearest_3d, 10.0 - 1e-9);
    EXPECT_LE(nearest_3d, 10.6);
  }
}

TEST_P(FootprintOnSurface, NanVoxelsNeverBecomeNanPoints) {
  const Surface s = surface();
  SCOPED_TRACE(s.name);
  VolumeF image = draw_bmode(s, /*seed=*/11u + unsigned(GetParam()));
  // A 3 mm ball of NaN on the band under the probe, and 2 % of all voxels NaN at random.
  Vector3d u, v, w;
  probe_frame(test_probe(), u, v, w);
  const ProbePose pose = test_probe();
  Vector3d hole = pose.face_centre + 5.0 * u;
  for (int it = 0; it < 50; ++it) hole -= s.signed_distance(hole) * w;  // onto the surface
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> uniform;
  const auto& g = image.geometry;
  for (int k = 0; k < g.size[2]; ++k)
    for (int j = 0; j < g.size[1]; ++j)
      for (int i = 0; i < g.size[0]; ++i)
        if ((g.index_to_world(Vector3d(i, j, k)) - hole).norm() < 3.0 || uniform(rng) < 0.02)
          image.at(i, j, k) = std::numeric_limits<float>::quiet_NaN();
  const FootprintResult r = extract_footprint(image, pose, wide_aperture());
  ASSERT_EQ(r.status, FootprintStatus::OK) << r.message;
  EXPECT_GT(r.missing_samples, 0);
  EXPECT_GE(r.points.rows(), 9);
  EXPECT_TRUE(r.points.allFinite());
  EXPECT_TRUE(r.normals.allFinite());
  const Accuracy a = measure(r, s);
  std::cout << "[ measured ] " << s.name << " with NaN voxels: max distance " << a.max_distance
            << " mm, max normal angle " << a.max_angle_deg << " deg\n";
  EXPECT_LE(a.max_distance, kMaxDistanceMm);
  EXPECT_LE(a.max_angle_deg, kMaxAngleDeg);
}

INSTANTIATE_TEST_SUITE_P(Surfaces, FootprintOnSurface, ::testing::Values(0, 1),
                         [](const ::testing::TestParamInfo<int>& param_info) {
                           return std::string(param_info.param == 0 ? "TiltedPlane" : "SphereCap");
                         });

TEST(Footprint, ThresholdCrossingFindsTheLeadingEdgeOfTheBand) {
  // The threshold lies between the dark level and the filtered band peak, so the crossing is on
  // the filtered leading edge of the band (at −0.75 mm): within 2.5 σ in front of it and at most
  // σ/2 behind it (σ = 1 mm, the default low-pass).
  const Surface s = tilted_plane(10.0, 18.0, 8.0);
  const VolumeF image = draw_bmode(s, 21u);
  FootprintOptions o = wide_aperture();
  o.depth_rule = FootprintDepthRule::THRESHOLD_CROSSING;
  const FootprintResult r = extract_footprint(image, test_probe(), o);
  ASSERT_EQ(r.status, FootprintStatus::OK) << r.message;
  ASSERT_GE(r.points.rows(), 9);
  for (Eigen::Index p = 0; p < r.points.rows(); ++p) {
    const double sd = s.signed_distance(r.points.row(p).transpose());
    EXPECT_GE(sd, -kBandHalfWidth - 2.5 * o.smoothing_sigma_mm);
    EXPECT_LE(sd, -kBandHalfWidth + 0.5 * o.smoothing_sigma_mm);
  }
}

TEST(Footprint, FractionOfMaxThresholdAlsoFindsTheSurface) {
  const Surface s = sphere_cap(8.0, 40.0);
  const VolumeF image = draw_bmode(s, 23u);
  FootprintOptions o = wide_aperture();
  o.threshold_rule = FootprintThreshold::FRACTION_OF_MAX;
  o.threshold_fraction = 0.4;
  const FootprintResult r = extract_footprint(image, test_probe(), o);
  ASSERT_EQ(r.status, FootprintStatus::OK) << r.message;
  EXPECT_EQ(r.threshold_rule, "fraction of max");
  EXPECT_GE(r.points.rows(), 9);
  const Accuracy a = measure(r, s);
  EXPECT_LE(a.max_distance, kMaxDistanceMm);
  EXPECT_LE(a.max_angle_deg, kMaxAngleDeg);
}

TEST(Footprint, DarkOrEmptyImagesHaveNoBandAndNoPoints) {
  const VolumeF bright = draw_bmode(sphere_cap(8.0, 40.0), 5u);
  const auto expect_no_band = [](const FootprintResult& r, const std::string& why) {
    EXPECT_EQ(r.status, FootprintStatus::NO_BAND);
    EXPECT_NE(r.message.find("no contact band found"), std::string::npos) << r.message;
    EXPECT_NE(r.message.find(why), std::string::npos) << r.message;
    EXPECT_EQ(r.points.rows(), 0);
    EXPECT_EQ(r.normals.rows(), 0);
  };
  VolumeF dark = bright;
  std::fill(dark.data.begin(), dark.data.end(), 0.0f);
  expect_no_band(extract_footprint(dark, test_probe(), wide_aperture()), "constant");
  FootprintOptions fraction = wide_aperture();
  fraction.threshold_rule = FootprintThreshold::FRACTION_OF_MAX;
  expect_no_band(extract_footprint(dark, test_probe(), fraction), "dark");

  // Speckle without a band: Otsu splits it, but the contrast stays far below 2.
  std::mt19937 rng(9);
  std::normal_distribution<double> normal;
  VolumeF noise = bright;
  for (float& x : noise.data) x = float(0.02 * std::abs(normal(rng)));
  expect_no_band(extract_footprint(noise, test_probe(), wide_aperture()), "contrast");

  VolumeF nan = bright;
  std::fill(nan.data.begin(), nan.data.end(), std::numeric_limits<float>::quiet_NaN());
  expect_no_band(extract_footprint(nan, test_probe(), wide_aperture()), "no image data");

  ProbePose far = test_probe();
  far.face_centre += Vector3d(500.0, 0.0, 0.0);
  expect_no_band(extract_footprint(bright, far, wide_aperture()), "no image data");

  expect_no_band(extract_footprint(VolumeF{}, test_probe(), wide_aperture()), "empty");
}

TEST(Footprint, BadInputsAreOneLineErrors) {
  const VolumeF image = draw_bmode(sphere_cap(8.0, 40.0), 5u);
  ProbePose zero_axis = test_probe();
  zero_axis.axis = Vector3d::Zero();
  tests::expect_error([&] { (void)extract_footprint(image, zero_axis); }, {"axis"});
  ProbePose parallel = test_probe();
  parallel.lateral = -2.0 * parallel.axis;
  tests::expect_error([&] { (void)extract_footprint(image, parallel); }, {"parallel"});
  FootprintOptions bad;
  bad.grid_step_mm = 0.0;
  bad.threshold_fraction = 1.5;
  tests::expect_error([&] { (void)extract_footprint(image, test_probe(), bad); },
                      {"grid_step_mm", "threshold_fraction"});
  VolumeF vector(image.geometry, 3);
  tests::expect_error([&] { (void)extract_footprint(vector, test_probe()); }, {"3 components"});
}

TEST(Footprint, WithoutLateralDirectionTheFrameIsStillRightHanded) {
  // Same image and probe, lateral left out: the lattice turns about the axis, the surface stays.
  const Surface s = sphere_cap(8.0, 40.0);
  const VolumeF image = draw_bmode(s, 29u);
  ProbePose pose = test_probe();
  pose.lateral.reset();
  FootprintOptions o = wide_aperture();
  o.aperture_elevation_mm = 40.0;  // a square aperture, so the turned grid covers the same cap
  const FootprintResult r = extract_footprint(image, pose, o);
  ASSERT_EQ(r.status, FootprintStatus::OK) << r.message;
  EXPECT_GE(r.points.rows(), 9);
  const Accuracy a = measure(r, s);
  EXPECT_LE(a.max_distance, kMaxDistanceMm);
  EXPECT_LE(a.max_angle_deg, kMaxAngleDeg);
}

}  // namespace
}  // namespace brainshift::imaging
