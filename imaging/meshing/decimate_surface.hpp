#pragma once
/// @file
/// @brief Decimation of a closed triangle surface to a few hundred vertices (the collision
/// surface of the registration) by CGAL edge collapse with the Lindstrom–Turk cost and placement
/// (Lindstrom & Turk, "Fast and memory efficient polygonal simplification", IEEE Vis 1998),
/// guarded against normal flips. Positions in mm, world frame.

#include "core/config.hpp"
#include "core/geometry/skeleton.hpp"

namespace brainshift::imaging {

/// Decimates a closed, manifold, consistently oriented triangle surface.
/// @param[in] surface          e.g. outer_boundary_surface().surface; normals outward.
/// @param[in] target_vertices  vertex count to reach (≥ 4); the result has this many ± a few
///                             (edge collapses stop at the matching edge count 3(V − χ)).
///                             A surface with fewer vertices is returned unchanged.
/// @return a closed manifold surface with outward normals, vertices near the input surface
/// (Lindstrom–Turk placement keeps the enclosed volume, so vertices may lie slightly outside).
/// \throws brainshift::Error when `surface` is not a closed manifold (open edge, an edge shared by
/// more than two triangles, an index out of range) or target_vertices < 4.
core::SurfaceMesh decimate_surface(const core::SurfaceMesh& surface, index_t target_vertices = 300);

/// Edges shared by more than two triangles: where parts of a closed boundary touch along an edge
/// (thin structures one element wide). decimate_surface() refuses such a surface;
/// make_collision_surface() (collision_surface.hpp) wraps it first.
index_t count_non_manifold_edges(const core::SurfaceMesh& surface);

}  // namespace brainshift::imaging
