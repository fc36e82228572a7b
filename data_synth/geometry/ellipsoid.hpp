#pragma once
/// @file
/// @brief Axis-aligned ellipsoid as an analytic implicit surface: inside test, level value,
/// outward normal and closest point. Used for the phantom's brain and skull surfaces (mm, world
/// RAS; the semi-axes are along the world axes R, A, S).

#include "core/config.hpp"

namespace brainshift::data_synth {

/// Ellipsoid {x : Σ ((x − c)_i / a_i)² ≤ 1}.
struct Ellipsoid {
  Vector3d centre = Vector3d::Zero();     ///< c, world RAS mm
  Vector3d semi_axes = Vector3d::Ones();  ///< a (along R, A, S), mm, > 0

  /// Σ ((x − c)_i / a_i)², dimensionless: < 1 inside, 1 on the surface, > 1 outside.
  [[nodiscard]] double level(const Vector3d& x) const {
    return (x - centre).cwiseQuotient(semi_axes).squaredNorm();
  }
  [[nodiscard]] bool contains(const Vector3d& x) const { return level(x) <= 1.0; }
  /// Volume 4/3 π a₀ a₁ a₂, mm³.
  [[nodiscard]] double volume() const;
  /// Unit outward normal of the level set through x (x ≠ c).
  [[nodiscard]] Vector3d normal(const Vector3d& x) const;
  /// Closest point on the surface to x (inside or outside), mm. Solved for the Lagrange multiplier
  /// t of x_i = c_i + a_i² p_i / (a_i² + t), p = x − c, by safeguarded Newton (Eberly,
  /// "Distance from a point to an ellipse, an ellipsoid, or a hyperellipsoid", 2013). Falls back
  /// to the radial projection in the degenerate inside case (x on a minor-axis plane).
  [[nodiscard]] Vector3d closest_point(const Vector3d& x) const;
};

}  // namespace brainshift::data_synth
