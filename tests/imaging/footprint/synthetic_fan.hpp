#pragma once
/// @file
/// @brief A synthetic freehand B-mode volume for the footprint tests: a sweep of fans (a sector
/// widening laterally from a flat near end, swept in elevation by translation or tilt) on a
/// randomly rotated grid, 0 outside, Rayleigh-speckled tissue inside and a bright near-field
/// band (what the RESECT volumes show: a band ≈ 2 mm thick at about twice the tissue's echo).

#include "random_rotation.hpp"

#include "imaging/io/volume.hpp"

#include <algorithm>
#include <cmath>
#include <random>

namespace brainshift::tests {

inline constexpr double kFanPi = 3.14159265358979323846;

/// A sweep of fans in its probe frame (x lateral, y elevation, z depth from the face, mm).
struct Fan {
  double near_width = 25.0;    // lateral extent at the face
  double half_angle_deg = 25;  // lateral widening
  double elevation = 30.0;     // elevation extent at the face
  double tilt_deg = 0.0;       // elevation widening (a tilted sweep), 0: translation
  double depth = 50.0;
  double band_mm = 2.0;    // bright near-field band
  double band_echo = 2.0;  // its mean echo over the tissue's
  [[nodiscard]] bool inside(const Vector3d& q) const {
    if (q.z() < 0.0 || q.z() > depth) return false;
    const double half_w = 0.5 * near_width + q.z() * std::tan(half_angle_deg * kFanPi / 180.0);
    const double half_e = 0.5 * elevation + q.z() * std::tan(tilt_deg * kFanPi / 180.0);
    return std::abs(q.x()) <= half_w && std::abs(q.y()) <= half_e;
  }
};

struct Scene {
  imaging::VolumeF image;
  Vector3d face_centre;
  Matrix3d frame;  // columns: lateral, elevation, beam
};

/// The fan rendered on a randomly rotated grid of 0.8 mm voxels: 0 outside, Rayleigh-speckled
/// tissue (mean 30) inside, the band over the first band_mm.
inline Scene render(const Fan& fan, unsigned seed) {
  std::mt19937 rng(seed);
  Scene s;
  s.face_centre = Vector3d(12.0, -30.0, 45.0);
  s.frame = random_rotation(rng);
  imaging::ImageGeometry g;
  g.direction = random_rotation(rng);
  g.spacing = Vector3d::Constant(0.8);
  const double reach =
      0.5 * fan.near_width + fan.depth * std::tan(fan.half_angle_deg * kFanPi / 180.0) + 2.0;
  const double reach_e =
      0.5 * fan.elevation + fan.depth * std::tan(fan.tilt_deg * kFanPi / 180.0) + 2.0;
  Vector3d lo = Vector3d::Constant(1e300), hi = -lo;
  for (int corner = 0; corner < 8; ++corner) {
    const Vector3d q((corner & 1) ? reach : -reach, (corner & 2) ? reach_e : -reach_e,
                     (corner & 4) ? fan.depth + 2.0 : -2.0);
    const Vector3d ijk = g.world_to_index(s.face_centre + s.frame * q);
    lo = lo.cwiseMin(ijk);
    hi = hi.cwiseMax(ijk);
  }
  g.origin = g.index_to_world(lo.array().floor().matrix());
  for (int a = 0; a < 3; ++a) g.size[a] = int(std::ceil(hi[a] - std::floor(lo[a]))) + 1;
  s.image = imaging::VolumeF(g);
  std::normal_distribution<double> normal;
  for (int k = 0; k < g.size[2]; ++k)
    for (int j = 0; j < g.size[1]; ++j)
      for (int i = 0; i < g.size[0]; ++i) {
        const Vector3d q =
            s.frame.transpose() * (g.index_to_world(Vector3d(i, j, k)) - s.face_centre);
        if (!fan.inside(q)) continue;
        const double mean = q.z() < fan.band_mm ? fan.band_echo : 1.0;
        const double rayleigh = std::hypot(normal(rng), normal(rng)) / 1.2533;  // mean 1
        s.image.at(i, j, k) = float(std::max(0.01, 30.0 * mean * rayleigh));
      }
  return s;
}

}  // namespace brainshift::tests
