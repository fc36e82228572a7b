#pragma once
/// @file
/// @brief Surfaces derived from a tetrahedral mesh for the constraints: the outer boundary
/// (collision surface), the default fixed region at the lowest part of the brain, and the dura
/// surface (outer boundary minus the craniotomy). Positions in mm, world RAS frame.

#include "core/geometry/skeleton.hpp"
#include "core/mesh/tet_mesh.hpp"

#include <vector>

namespace brainshift::imaging {

/// A surface whose vertices are nodes of a tetrahedral mesh.
struct MeshSurface {
  core::SurfaceMesh surface;  ///< vertices (mm, world) and triangles, normals outward
  std::vector<index_t> node;  ///< #V tet-mesh node of each surface vertex
};

/// The outer boundary of `mesh`: triangles that belong to exactly one tetrahedron, restricted to
/// the connected component (by shared vertices) holding the node with the largest x, so inner
/// boundaries (a ventricle cavity) are left out. Triangles are oriented with outward normals
/// (counter-clockwise seen from outside); vertices are numbered in increasing node order.
/// \pre `mesh` is positively oriented (core::validate()).
/// \throws brainshift::Error when the mesh has no tetrahedron.
MeshSurface outer_boundary_surface(const core::TetMesh& mesh);

/// Default fixed region: the surface nodes at the bottom of the brain, those within `height` mm
/// of the lowest surface point measured along `down` (the caudal direction; RAS −z by default).
/// @param[in] outer   from outer_boundary_surface().
/// @param[in] down    direction pointing down (caudal), world frame; need not be unit, ≠ 0.
/// @param[in] height  mm, ≥ 0.
/// @return tet-mesh node indices, increasing.
std::vector<index_t> fixed_region_nodes(const MeshSurface& outer,
                                        const Vector3d& down = Vector3d(0.0, 0.0, -1.0),
                                        double height = 15.0);

/// Dura surface: the outer surface minus the craniotomy, i.e. without the triangles whose
/// centroid lies within `radius` mm (Euclidean, world) of `centre`; unused vertices removed.
/// @param[in] outer   from outer_boundary_surface().
/// @param[in] centre  craniotomy centre, mm, world (on or near the surface).
/// @param[in] radius  craniotomy radius, mm, ≥ 0.
/// \note The removed region is the intersection of the surface with a ball, which on a smooth
/// surface is the disc-like cap of the craniotomy.
MeshSurface dura_surface(const MeshSurface& outer, const Vector3d& centre, double radius);

}  // namespace brainshift::imaging
