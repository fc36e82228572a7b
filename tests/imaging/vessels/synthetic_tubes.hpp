#pragma once
/// @file
/// @brief Analytic tube phantoms for the vessel tests: voxels whose centre lies within the
/// radius of any axis segment are bright, the rest are background.

#include "imaging/io/volume.hpp"

#include <algorithm>
#include <utility>
#include <vector>

namespace brainshift::tests {

/// One straight piece of vessel axis, world RAS mm.
struct AxisSegment {
  Vector3d a, b;
};

/// Distance (mm) from `p` to segment [a, b].
inline double distance_to_segment(const Vector3d& p, const Vector3d& a, const Vector3d& b) {
  const Vector3d ab = b - a;
  const double t = std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
  return (a + t * ab - p).norm();
}

/// Distance (mm) from `p` to the nearest of `axes`.
inline double distance_to_axes(const Vector3d& p, const std::vector<AxisSegment>& axes) {
  double d = 1e300;
  for (const auto& s : axes) d = std::min(d, distance_to_segment(p, s.a, s.b));
  return d;
}

/// A volume with value `inside` where the voxel centre is within `radius` (mm) of an axis, else
/// `outside`.
inline imaging::VolumeF draw_tubes(const imaging::ImageGeometry& g,
                                   const std::vector<AxisSegment>& axes, double radius,
                                   float inside = 1000.0f, float outside = 100.0f) {
  imaging::VolumeF v(g, 1, outside);
  for (int k = 0; k < g.size[2]; ++k)
    for (int j = 0; j < g.size[1]; ++j)
      for (int i = 0; i < g.size[0]; ++i)
        if (distance_to_axes(g.index_to_world(Vector3d(i, j, k)), axes) <= radius)
          v.at(i, j, k) = inside;
  return v;
}

/// A grid of `n` voxels of 1 mm with its origin at 0, identity direction.
inline imaging::ImageGeometry unit_grid(const Eigen::Vector3i& n) {
  imaging::ImageGeometry g;
  g.size = n;
  return g;
}

}  // namespace brainshift::tests
