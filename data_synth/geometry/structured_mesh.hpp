#pragma once
/// @file
/// @brief Structured tetrahedral meshes (box, cylinder, ellipsoid) for tests, benchmarks and the
/// forward-simulation demo. Each hexahedral cell is split into six tetrahedra around its main
/// diagonal (Kuhn subdivision), so the mesh is conforming and every tetrahedron is positively
/// oriented. Lengths in mm, world frame.

#include "core/mesh/tet_mesh.hpp"

namespace brainshift::data_synth {

/// Box [0, size.x] × [0, size.y] × [0, size.z] (mm) with `cells` hexahedra per axis, offset by
/// `origin` (mm). Nodes are numbered x fastest, then y, then z: (i, j, k) → i + (nx+1)(j +
/// (ny+1)k).
core::TetMesh make_box_mesh(const Vector3d& size, const Eigen::Vector3i& cells,
                            const Vector3d& origin = Vector3d::Zero());

/// Cylinder of radius `radius` and length `length` (mm) along +z, axis through `centre` of its
/// base; `radial_cells` cells across the diameter, `axial_cells` along the axis. Built by mapping
/// the square cross-section smoothly onto the disc (no degenerate axis).
core::TetMesh make_cylinder_mesh(double radius, double length, int radial_cells, int axial_cells,
                                 const Vector3d& centre = Vector3d::Zero());

/// Ellipsoid with semi-axes `semi_axes` (mm) centred at `centre`, `cells` cells across each
/// axis, by mapping the cube smoothly onto the ball.
core::TetMesh make_ellipsoid_mesh(const Vector3d& semi_axes, int cells,
                                  const Vector3d& centre = Vector3d::Zero());

}  // namespace brainshift::data_synth
