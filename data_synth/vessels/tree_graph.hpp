#pragma once
/// @file
/// @brief Conversions between the phantom's VesselTree and imaging::VesselGraph (the .vtp
/// skeleton files), and placement of a user-given tree (e.g. segmented from a real MRA) into the
/// phantom. Positions world RAS mm, radii mm.

#include "data_synth/geometry/brain_phantom.hpp"
#include "data_synth/vessels/vessel_tree.hpp"
#include "imaging/vessels/skeleton_graph.hpp"

namespace brainshift::data_synth {

/// The tree as a graph: nodes at the points of degree ≠ 2, one branch per chain between them.
imaging::VesselGraph to_vessel_graph(const VesselTree& tree);

/// A graph as a tree: node and branch points become tree points (shared nodes once), each
/// polyline segment an edge; generations by breadth-first search from the thickest end point
/// of each component, +1 at every junction.
VesselTree from_vessel_graph(const imaging::VesselGraph& graph);

struct TreePlacement {
  double target_extent = 70.0;  ///< the largest bounding-box side is scaled to this, mm, > 0
  double depth = 12.0;          ///< the centroid goes this deep below the craniotomy centre, mm
  double default_radius = 1.0;  ///< radius for points given with radius ≤ 0, mm
  double min_radius = 0.5;      ///< radii (after scaling) are clamped to [min, max], mm
  double max_radius = 3.0;
};

/// Scales a user tree uniformly (radii too) to target_extent, centres it under the craniotomy,
/// and pulls every point that falls outside the brain (or into the tumour or ventricles) back
/// inside: onto the surface 2 mm deep, or 1 mm outside the tumour. Ventricle points are moved
/// toward the brain surface until they leave the ventricle.
/// \throws brainshift::Error when the tree is empty or invalid.
VesselTree place_user_tree(const VesselTree& user, const PhantomGeometry& geometry,
                           const TreePlacement& placement = {});

}  // namespace brainshift::data_synth
