#pragma once
/// @file
/// @brief Closest points on segments and triangles (Ericson, Real-Time Collision Detection, §5.1).

#include "core/config.hpp"

namespace brainshift::core {

/// Closest point of triangle (a, b, c) to p, returned as barycentric weights of (a, b, c)
/// (Ericson §5.1.5; exact Voronoi-region classification, no division by zero for proper triangles).
Vector3d closest_point_on_triangle(const Vector3d& p, const Vector3d& a, const Vector3d& b,
                                   const Vector3d& c);

/// Parameter t ∈ [0, 1] of the closest point a + t (b − a) of segment [a, b] to p; 0 when a = b.
double closest_point_on_segment(const Vector3d& p, const Vector3d& a, const Vector3d& b);

}  // namespace brainshift::core
