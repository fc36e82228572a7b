#pragma once
/// @file
/// @brief The collision surface of the registration: the outer boundary of the tetrahedral mesh,
/// decimated to a few hundred vertices (decimate_surface.hpp). A boundary that is not a closed
/// 2-manifold (on real brains, thin parts touch along an edge or at a vertex) is first replaced by
/// its alpha wrap (wrap_surface.hpp), which is; vertices that decimation leaves too far outside
/// the mesh are then moved onto it, so every vertex maps into the mesh (the registration accepts
/// up to 2 mm outside). Positions in mm, world RAS frame.

#include "core/geometry/skeleton.hpp"
#include "core/mesh/tet_mesh.hpp"
#include "imaging/meshing/boundary_surface.hpp"

#include <string>

namespace brainshift::imaging {

/// Size and repair settings of make_collision_surface(). Lengths in mm.
struct CollisionSurfaceOptions {
  index_t target_vertices = 300;  ///< decimation target (≥ 4)
  /// Alpha wrap of a non-manifold boundary: gaps narrower than `wrap_alpha_mm` are bridged (a
  /// few mm: sulci and touching gyri, far below the ≈ 15 mm edges of a 300-vertex brain surface)
  /// and the wrap lies ≈ `wrap_offset_mm` outside the boundary (adds ≈ offset × area of volume).
  /// On ICBM152 (2,449 boundary vertices) alpha 4 / offset 0.3 mm take 40 % less time than
  /// 3 / 0.25 and add 1.1 % to the mesh's volume (3 / 0.25: 0.5 %; 5 / 0.5: 1.9 %).
  double wrap_alpha_mm = 4.0;
  double wrap_offset_mm = 0.3;
  /// Vertices farther than this outside the mesh are moved to its nearest point (< 2 mm, the
  /// registration's limit).
  double max_outside_mm = 1.5;
  /// Empty when valid, else one line naming the first bad field and its value.
  [[nodiscard]] std::string validate() const;
};

/// The collision surface and how it was made.
struct CollisionSurface {
  core::SurfaceMesh surface;          ///< closed 2-manifold, outward normals, mm
  index_t boundary_vertices = 0;      ///< of the mesh's outer boundary
  index_t non_manifold_edges = 0;     ///< boundary edges shared by more than two triangles
  index_t non_manifold_vertices = 0;  ///< boundary vertices whose triangles do not form one fan
  bool wrapped = false;               ///< the boundary was not a manifold and was alpha-wrapped
  index_t moved_vertices = 0;         ///< vertices moved onto the mesh (were > max_outside_mm out)
  double max_outside_mm = 0.0;  ///< largest distance of a vertex outside the mesh before moving, mm
};

/// Builds the collision surface of `mesh` from its outer boundary `outer`.
/// @param[in] mesh     tetrahedral mesh, mm, world.
/// @param[in] outer    outer_boundary_surface(mesh).
/// @param[in] options  see CollisionSurfaceOptions.
/// \throws brainshift::Error when the options are invalid or `outer` has no triangle.
CollisionSurface make_collision_surface(const core::TetMesh& mesh, const MeshSurface& outer,
                                        const CollisionSurfaceOptions& options = {});

/// Vertices whose incident triangles do not form a single fan (one cycle around the vertex):
/// where parts of a boundary touch at a point or along an edge. 0 on a closed 2-manifold.
index_t count_non_manifold_vertices(const core::SurfaceMesh& surface);

}  // namespace brainshift::imaging
