#pragma once
/// @file
/// @brief Brute-force checks of triangle surfaces for the meshing tests: closedness, enclosed
/// volume, area, vertex-sampled Hausdorff distance.

#include "core/geometry/skeleton.hpp"
#include "core/mapping/closest_point.hpp"

#include <algorithm>
#include <limits>
#include <map>
#include <utility>

namespace brainshift::imaging {

/// Every directed edge occurs once and its reverse once: closed, manifold along edges, and
/// consistently oriented.
inline bool is_closed_and_consistent(const core::SurfaceMesh& s) {
  std::map<std::pair<index_t, index_t>, int> directed;
  for (index_t f = 0; f < s.triangles.rows(); ++f) {
    for (int c = 0; c < 3; ++c) ++directed[{s.triangles(f, c), s.triangles(f, (c + 1) % 3)}];
  }
  for (const auto& [edge, count] : directed) {
    if (count != 1) return false;
    const auto reverse = directed.find({edge.second, edge.first});
    if (reverse == directed.end() || reverse->second != 1) return false;
  }
  return true;
}

/// Σ v0 · (v1 × v2) / 6: the enclosed volume (mm³), positive for outward normals.
inline double enclosed_volume(const core::SurfaceMesh& s) {
  double v = 0.0;
  for (index_t f = 0; f < s.triangles.rows(); ++f) {
    const Vector3d a = s.vertices.row(s.triangles(f, 0)), b = s.vertices.row(s.triangles(f, 1)),
                   c = s.vertices.row(s.triangles(f, 2));
    v += a.dot(b.cross(c)) / 6.0;
  }
  return v;
}

inline double surface_area(const core::SurfaceMesh& s) {
  double area = 0.0;
  for (index_t f = 0; f < s.triangles.rows(); ++f) {
    const Vector3d a = s.vertices.row(s.triangles(f, 0)), b = s.vertices.row(s.triangles(f, 1)),
                   c = s.vertices.row(s.triangles(f, 2));
    area += 0.5 * (b - a).cross(c - a).norm();
  }
  return area;
}

/// Distance from p to the surface (brute force over triangles), mm.
inline double distance_to_surface(const Vector3d& p, const core::SurfaceMesh& s) {
  double best = std::numeric_limits<double>::infinity();
  for (index_t f = 0; f < s.triangles.rows(); ++f) {
    const Vector3d a = s.vertices.row(s.triangles(f, 0)), b = s.vertices.row(s.triangles(f, 1)),
                   c = s.vertices.row(s.triangles(f, 2));
    const Vector3d w = core::closest_point_on_triangle(p, a, b, c);
    best = std::min(best, (p - (w[0] * a + w[1] * b + w[2] * c)).norm());
  }
  return best;
}

/// max over the vertices of each surface of the distance to the other (a lower bound of the
/// Hausdorff distance, tight when the surfaces are finely sampled), mm.
inline double vertex_hausdorff(const core::SurfaceMesh& s1, const core::SurfaceMesh& s2) {
  double h = 0.0;
  for (index_t v = 0; v < s1.vertices.rows(); ++v) {
    h = std::max(h, distance_to_surface(s1.vertices.row(v).transpose(), s2));
  }
  for (index_t v = 0; v < s2.vertices.rows(); ++v) {
    h = std::max(h, distance_to_surface(s2.vertices.row(v).transpose(), s1));
  }
  return h;
}

}  // namespace brainshift::imaging
