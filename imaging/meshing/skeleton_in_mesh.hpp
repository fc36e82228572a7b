#pragma once
/// @file
/// @brief The pre-operative vessel skeleton fitted to the tetrahedral mesh. Real cortical vessels
/// lie on the pial surface and in the sulci, on or just outside the brain label (and the mesh,
/// whose boundary cuts the label's convex parts by up to its facet distance): points outside the
/// mesh within a snap distance are moved to the nearest point of the mesh, points farther out are
/// dropped and counted. Positions in mm, world RAS frame.

#include "core/mesh/tet_mesh.hpp"
#include "imaging/vessels/skeleton_graph.hpp"

namespace brainshift::imaging {

/// What fit_skeleton_to_mesh() did, point by point.
struct SkeletonFit {
  VesselGraph graph;          ///< the kept runs as branches (≥ 2 points each), all in the mesh
  index_t points = 0;         ///< branch points of the input (shared end points counted per branch)
  index_t inside = 0;         ///< kept where they were (inside the mesh)
  index_t snapped = 0;        ///< outside but within the snap distance: moved onto the mesh
  index_t dropped = 0;        ///< farther out than the snap distance, or left alone (a run of one)
  double max_snap_mm = 0.0;   ///< largest move of a snapped point, mm
  double mean_snap_mm = 0.0;  ///< mean move of the snapped points, mm (0 when none)
};

/// Fits `graph` to `mesh`: every branch point inside the mesh stays; one outside within
/// `snap_distance_mm` of the mesh moves to the nearest point of the mesh (its nearest
/// tetrahedron's closest point); one farther out is dropped, which cuts its branch. Each run of
/// two or more kept consecutive points becomes a branch (radii kept); a run that starts or ends
/// where the original branch did keeps that end's node, so junctions stay shared.
/// @param[in] graph             vessel skeleton, world RAS mm.
/// @param[in] mesh              tetrahedral mesh, world RAS mm.
/// @param[in] snap_distance_mm  mm, ≥ 0.
/// \throws brainshift::Error when snap_distance_mm is negative or not finite, or the mesh has no
/// tetrahedron.
SkeletonFit fit_skeleton_to_mesh(const VesselGraph& graph, const core::TetMesh& mesh,
                                 double snap_distance_mm = 5.0);

}  // namespace brainshift::imaging
