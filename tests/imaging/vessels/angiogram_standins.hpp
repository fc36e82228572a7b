#pragma once
/// @file
/// @brief Realistic stand-ins for the real angiograms of issue 13 that are not in the shared
/// data, with their true centrelines:
///  - a background-suppressed uint8 TOF MRA of a circle of Willis (0.52 × 0.52 × 0.65 mm, 99 %
///    of voxels 0, vessels 100–254, a float32-rounded oblique direction matrix);
///  - a raw int16 TOF slab of a head (air noise, dark skull, a bright fat/skin shell, tissue,
///    vessels brighter than tissue);
///  - a noisy angiogram of 8 tubes of ≈ 300 mm in all, on tissue with a coil bias and spatially
///    correlated noise (what reconstruction and interpolation leave in a real MRA).
/// Every generator is deterministic (fixed seeds).

#include "synthetic_tubes.hpp"

#include "imaging/filters/gaussian.hpp"
#include "imaging/io/volume.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

namespace brainshift::tests {

/// A straight vessel piece with its radius (mm).
struct VesselPiece {
  Vector3d a, b;
  double radius;
};

/// A stand-in image and its truth.
struct Angiogram {
  imaging::VolumeF image;
  std::vector<VesselPiece> vessels;  ///< world RAS mm
  [[nodiscard]] std::vector<AxisSegment> axes() const {
    std::vector<AxisSegment> s;
    for (const auto& v : vessels) s.push_back({v.a, v.b});
    return s;
  }
  [[nodiscard]] double length() const {
    double l = 0.0;
    for (const auto& v : vessels) l += (v.b - v.a).norm();
    return l;
  }
};

/// A circle of Willis with its main branches about `centre` (mm, RAS; x right, y anterior,
/// z superior), scaled by `scale`: the ring (AComm, A1s, PComms, P1s), the internal carotids and
/// the basilar below it, the MCAs, ACAs and PCAs beyond it. 19 pieces, ≈ 277 mm at scale 1.
inline std::vector<VesselPiece> circle_of_willis(const Vector3d& centre, double scale = 1.0) {
  const auto p = [&](double x, double y, double z) {
    return Vector3d(centre + scale * Vector3d(x, y, z));
  };
  const Vector3d a1l = p(-6, 9, 0), a1r = p(6, 9, 0), ical = p(-12, 0, 0), icar = p(12, 0, 0);
  const Vector3d p1l = p(-7, -10, 0), p1r = p(7, -10, 0), ba = p(0, -13, -1);
  return {{a1l, a1r, 0.9},  // anterior communicating
          {a1l, ical, 1.1},
          {a1r, icar, 1.1},  // A1
          {ical, p1l, 0.9},
          {icar, p1r, 0.9},  // posterior communicating
          {p1l, ba, 1.1},
          {p1r, ba, 1.1},  // P1
          {ical, p(-13, 3, -16), 2.0},
          {icar, p(13, 3, -16), 2.0},  // internal carotids
          {ba, p(0, -15, -19), 1.5},   // basilar
          {ical, p(-27, 5, 4), 1.4},
          {p(-27, 5, 4), p(-36, 12, 9), 1.2},  // left MCA
          {icar, p(27, 5, 4), 1.4},
          {p(27, 5, 4), p(36, 12, 9), 1.2},  // right MCA
          {a1l, p(-3, 22, 10), 1.0},
          {p(-3, 22, 10), p(-3, 32, 18), 1.0},  // left ACA
          {a1r, p(3, 22, 10), 1.0},             // right ACA
          {p1l, p(-22, -30, 6), 1.0},
          {p1r, p(22, -30, 6), 1.0}};  // PCAs
}

/// For each voxel: the normalised distance d/r to the nearest vessel (by d/r), ≥ 0; large
/// outside every vessel.
inline imaging::VolumeF relative_distance(const imaging::ImageGeometry& g,
                                          const std::vector<VesselPiece>& vessels) {
  imaging::VolumeF out(g, 1, 1e9F);
  for (const auto& v : vessels) {
    // Only the voxels of the piece's world bounding box (grown by its radius and a voxel).
    const Vector3d grow = Vector3d::Constant(v.radius + g.spacing.maxCoeff());
    const Vector3d box_lo = v.a.cwiseMin(v.b) - grow, box_hi = v.a.cwiseMax(v.b) + grow;
    Eigen::Vector3i lo = g.size, hi = Eigen::Vector3i::Constant(-1);
    for (int c = 0; c < 8; ++c) {
      const Vector3d corner((c & 1) ? box_hi.x() : box_lo.x(), (c & 2) ? box_hi.y() : box_lo.y(),
                            (c & 4) ? box_hi.z() : box_lo.z());
      const Vector3d ijk = g.world_to_index(corner);
      for (int a = 0; a < 3; ++a) {
        lo[a] = std::min(lo[a], std::max(0, int(std::floor(ijk[a]))));
        hi[a] = std::max(hi[a], std::min(g.size[a] - 1, int(std::ceil(ijk[a]))));
      }
    }
    for (int k = lo[2]; k <= hi[2]; ++k)
      for (int j = lo[1]; j <= hi[1]; ++j)
        for (int i = lo[0]; i <= hi[0]; ++i) {
          const double d =
              distance_to_segment(g.index_to_world(Vector3d(i, j, k)), v.a, v.b) / v.radius;
          out.at(i, j, k) = std::min(out.at(i, j, k), float(d));
        }
  }
  return out;
}

/// Zero-mean Gaussian noise of standard deviation `sigma`, smoothed by a Gaussian of
/// `correlation_mm` (then rescaled to `sigma`): spatially correlated like reconstructed MR noise.
inline imaging::VolumeF correlated_noise(const imaging::ImageGeometry& g, double sigma,
                                         double correlation_mm, std::uint32_t seed) {
  imaging::VolumeF n(g, 1, 0.0F);
  std::mt19937 rng(seed);
  std::normal_distribution<float> normal(0.0F, 1.0F);
  for (float& x : n.data) x = normal(rng);
  if (correlation_mm > 0.0) n = imaging::filters::gaussian_filter(n, correlation_mm);
  double sum2 = 0.0;
  for (const float x : n.data) sum2 += double(x) * x;
  const float scale = float(sigma / std::sqrt(sum2 / double(n.data.size())));
  for (float& x : n.data) x *= scale;
  return n;
}

/// The float32 rounding of a rotation as a NIfTI sform stores it, plus an error of ≈ 1.3e-6
/// (as in the real file): orthonormal only to single precision.
inline Matrix3d float_rounded_rotation() {
  Matrix3d r =
      (Eigen::AngleAxisd(0.12, Vector3d::UnitZ()) * Eigen::AngleAxisd(-0.08, Vector3d::UnitX()))
          .toRotationMatrix();
  r(0, 1) += 1.3e-6;
  return r.cast<float>().cast<double>();
}

/// The background-suppressed uint8 TOF stand-in (0.52 × 0.52 × 0.65 mm, oblique float direction).
inline Angiogram suppressed_tof() {
  imaging::ImageGeometry g;
  g.spacing = {0.52, 0.52, 0.65};
  g.size = {170, 150, 70};  // 88 × 78 × 45.5 mm
  g.direction = float_rounded_rotation();
  const Vector3d half =
      0.5 * g.spacing.cwiseProduct((g.size - Eigen::Vector3i::Ones()).cast<double>());
  g.origin = Vector3d(10.0, -20.0, 5.0) - g.direction * half;  // grid centred on (10, −20, 5)
  Angiogram a;
  a.vessels = circle_of_willis(Vector3d(10.0, -20.0, 8.0) + Vector3d(0, 0, 0));
  const imaging::VolumeF d = relative_distance(g, a.vessels);
  a.image = imaging::VolumeF(g, 1, 0.0F);
  std::mt19937 rng(13);
  std::normal_distribution<float> noise(0.0F, 8.0F);
  std::uniform_real_distribution<float> u(0.0F, 1.0F);
  for (std::size_t v = 0; v < d.data.size(); ++v) {
    const float r = d.data[v];
    // Flow-related enhancement: brightest on the axis; the suppression sets all below 100 to 0.
    const float value = r <= 1.0F ? 110.0F + 140.0F * std::sqrt(1.0F - r * r) + noise(rng) : 0.0F;
    a.image.data[v] = value >= 100.0F ? std::round(std::min(value, 254.0F)) : 0.0F;
  }
  // Residual specks the suppression kept (fat, flow artefacts): a few bright voxels.
  for (int s = 0; s < 300; ++s) {
    const int i = int(u(rng) * float(g.size[0] - 1)), j = int(u(rng) * float(g.size[1] - 1)),
              k = int(u(rng) * float(g.size[2] - 1));
    a.image.at(i, j, k) = std::round(100.0F + 100.0F * u(rng));
  }
  return a;
}

/// The raw int16 TOF slab stand-in: 0.7 mm voxels, a head (ellipsoid) with brain tissue 250,
/// a dark skull layer, a bright fat/skin shell 800 (as bright as the vessels), air noise outside,
/// vessels 650–950; Gaussian noise σ 20; the slab cuts the head above and below.
inline Angiogram raw_tof_with_fat() {
  imaging::ImageGeometry g;
  g.spacing = {0.7, 0.7, 0.7};
  g.size = {180, 196, 80};  // 126 × 137 × 56 mm
  const Vector3d centre(0.0, 0.0, 0.0);
  g.origin =
      centre - 0.5 * g.spacing.cwiseProduct((g.size - Eigen::Vector3i::Ones()).cast<double>());
  g.origin.z() = -25.0;
  Angiogram a;
  a.vessels = circle_of_willis(centre, 0.9);
  const imaging::VolumeF d = relative_distance(g, a.vessels);
  a.image = imaging::VolumeF(g, 1, 0.0F);
  std::mt19937 rng(17);
  std::normal_distribution<float> noise(0.0F, 20.0F);
  const Vector3d semi(46.0, 52.0, 40.0);
  for (int k = 0; k < g.size[2]; ++k)
    for (int j = 0; j < g.size[1]; ++j)
      for (int i = 0; i < g.size[0]; ++i) {
        const Vector3d p = g.index_to_world(Vector3d(i, j, k));
        const double s = (p - centre).cwiseQuotient(semi).norm();
        const float r = d.at(i, j, k);
        float value;
        if (s > 1.27)
          value = std::abs(noise(rng)) * 0.75F;  // air: magnitude noise
        else if (s > 1.14)
          value = 800.0F + noise(rng);  // fat and skin
        else if (s > 1.0)
          value = 40.0F + noise(rng);  // skull and CSF
        else if (r <= 1.0F)
          value = 650.0F + 300.0F * std::sqrt(1.0F - r * r) + noise(rng);
        else
          value = 250.0F + noise(rng);  // brain
        a.image.at(i, j, k) = std::round(std::clamp(value, 0.0F, 32767.0F));
      }
  return a;
}

/// The noisy angiogram stand-in: 8 tubes of 37.5 mm (300 mm in all), radius 1 mm, in a brain
/// (ellipsoid, tissue 200 with a coil bias of ±35 % across it and spatially correlated noise:
/// σ 30, correlation 0.8 mm) surrounded by air (magnitude noise); 0.5 mm voxels; vessels
/// 200 + 330 on the axis (before the bias).
inline Angiogram noisy_angiogram() {
  imaging::ImageGeometry g;
  g.spacing = {0.5, 0.5, 0.5};
  g.size = {180, 180, 100};  // 90 × 90 × 50 mm
  const Vector3d centre(45.0, 45.0, 25.0), semi(40.0, 40.0, 22.0);
  const auto brain = [&](const Vector3d& p) { return (p - centre).cwiseQuotient(semi).norm(); };
  Angiogram a;
  std::mt19937 rng(23);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  while (a.vessels.size() < 8) {
    // A straight tube of 37.5 mm through a random point, in a random direction, inside the brain.
    const Vector3d c =
        centre + 0.5 * semi.cwiseProduct(Vector3d(u(rng) - 0.5, u(rng) - 0.5, u(rng) - 0.5));
    const Vector3d dir = Vector3d(u(rng) - 0.5, u(rng) - 0.5, 0.4 * (u(rng) - 0.5)).normalized();
    const VesselPiece v{c - 18.75 * dir, c + 18.75 * dir, 1.0};
    if (brain(v.a) < 0.85 && brain(v.b) < 0.85) a.vessels.push_back(v);
  }
  const imaging::VolumeF d = relative_distance(g, a.vessels);
  const imaging::VolumeF n = correlated_noise(g, 30.0, 0.8, 29);
  a.image = imaging::VolumeF(g, 1, 0.0F);
  std::normal_distribution<double> air(0.0, 12.0);
  for (int k = 0; k < g.size[2]; ++k)
    for (int j = 0; j < g.size[1]; ++j)
      for (int i = 0; i < g.size[0]; ++i) {
        const Vector3d p = g.index_to_world(Vector3d(i, j, k));
        if (brain(p) > 1.0) {
          a.image.at(i, j, k) = float(std::hypot(air(rng), air(rng)));
          continue;
        }
        const double bias = 1.0 + 0.35 * (p.x() - centre.x()) / semi.x();
        const float r = d.at(i, j, k);
        const double vessel = r <= 1.0F ? 330.0 * std::sqrt(1.0 - double(r) * r) : 0.0;
        a.image.at(i, j, k) = float(std::max(0.0, bias * (200.0 + vessel) + n.at(i, j, k)));
      }
  return a;
}

}  // namespace brainshift::tests
