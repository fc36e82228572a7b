#pragma once
/// @file
/// @brief Boundary of a tetrahedral mesh: the faces that belong to exactly one tetrahedron,
/// oriented outward (counter-clockwise seen from outside, so (b − a) × (c − a) points out).

#include "core/config.hpp"
#include "core/mesh/tet_mesh.hpp"

#include <vector>

namespace brainshift::core {

using TriangleMatrix = Eigen::Matrix<index_t, Eigen::Dynamic, 3, Eigen::RowMajor>;

/// Boundary faces of `mesh` (#F×3 node indices), outward, in a deterministic order.
/// \pre the mesh is positively oriented (core::validate()).
TriangleMatrix boundary_faces(const TetMesh& mesh);

/// The boundary as a stand-alone surface: its used nodes (#V×3, mm) and faces re-indexed into
/// them; `node_of_vertex[v]` is the mesh node of surface vertex v.
struct BoundarySurface {
  MatrixX3d vertices;
  TriangleMatrix faces;
  std::vector<index_t> node_of_vertex;
};
BoundarySurface boundary_surface(const TetMesh& mesh);

}  // namespace brainshift::core
