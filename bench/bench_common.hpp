#pragma once
/// @file
/// @brief Shared scenes for the micro-benchmarks: a brain-hemisphere-sized ellipsoid, its
/// Dirichlet cap and a smoothly bent configuration with nodal rotations of at most 10°.

#include "core/config.hpp"
#include "core/mesh/tet_mesh.hpp"
#include "data_synth/geometry/structured_mesh.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

namespace brainshift::bench {

/// Semi-axes of the phantom (mm): roughly one brain hemisphere's bounding ellipsoid.
inline const Vector3d& hemisphere_semi_axes() {
  static const Vector3d axes(70.0, 60.0, 50.0);
  return axes;
}

/// Ellipsoid with `cells` cells per axis: (cells + 1)³ nodes (12 → 2,197; 26 → 19,683;
/// 46 → 103,823).
inline core::TetMesh hemisphere_mesh(int cells) {
  return data_synth::make_ellipsoid_mesh(hemisphere_semi_axes(), cells);
}

/// Dirichlet nodes: the bottom cap, z < −45 mm (the ellipsoid reaches −50 mm).
inline std::vector<index_t> bottom_cap(const core::TetMesh& mesh) {
  std::vector<index_t> out;
  for (index_t i = 0; i < mesh.num_nodes(); ++i)
    if (mesh.nodes()(i, 2) < -45.0) out.push_back(i);
  return out;
}

/// Scaled radius |(x/a, y/b, z/c)| of a point (1 on the ellipsoid surface).
inline double scaled_radius(const Vector3d& p) {
  return p.cwiseQuotient(hemisphere_semi_axes()).norm();
}

/// A smooth, realistic intra-operative configuration: every node is rotated about the x axis
/// through the bottom pole (0, 0, −50) by an angle growing linearly from 0 at the bottom to
/// `max_degrees` at the top. The element and nodal rotations it induces are ≤ max_degrees.
inline MatrixX3d bent_configuration(const core::TetMesh& mesh, double max_degrees = 10.0) {
  const double c = hemisphere_semi_axes().z();
  const Vector3d pivot(0.0, 0.0, -c);
  MatrixX3d x(mesh.num_nodes(), 3);
  for (index_t i = 0; i < mesh.num_nodes(); ++i) {
    const Vector3d X = mesh.nodes().row(i).transpose();
    const double t = std::clamp((X.z() + c) / (2 * c), 0.0, 1.0);
    const double angle = t * max_degrees * std::numbers::pi / 180.0;
    const Eigen::AngleAxisd R(angle, Vector3d::UnitX());
    x.row(i) = (pivot + R * (X - pivot)).transpose();
  }
  return x;
}

}  // namespace brainshift::bench
