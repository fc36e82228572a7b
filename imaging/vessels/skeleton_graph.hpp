#pragma once
/// @file
/// @brief Vessel skeleton graphs: nodes (junctions and end points) joined by branches
/// (polylines), positions in world RAS mm, radii in mm. Built from a thinned voxel mask, pruned
/// of short spurs, smoothed and resampled; convertible to core::Skeleton.

#include "core/config.hpp"
#include "core/geometry/skeleton.hpp"
#include "imaging/io/volume.hpp"

#include <cstdint>
#include <vector>

namespace brainshift::imaging {

/// A graph of vessel centrelines.
struct VesselGraph {
  /// A junction (degree ≥ 3), an end point (degree 1), or a point chosen on a closed loop.
  struct Node {
    Vector3d position = Vector3d::Zero();  ///< world RAS, mm
    double radius = 0.0;                   ///< vessel radius, mm
  };
  /// A centreline between two nodes (the same node for a closed loop).
  struct Branch {
    index_t from = 0;              ///< node index of points.front()
    index_t to = 0;                ///< node index of points.back()
    std::vector<Vector3d> points;  ///< world RAS mm, from node `from` to node `to`, ≥ 2
    std::vector<double> radius;    ///< mm, one per point
  };
  std::vector<Node> nodes;
  std::vector<Branch> branches;

  /// Number of branch ends at each node (a loop counts twice).
  [[nodiscard]] std::vector<int> degrees() const;
  /// Sum of the branch polyline lengths, mm.
  [[nodiscard]] double total_length() const;
  /// Nodes of degree ≥ 3.
  [[nodiscard]] int junction_count() const;
  /// Nodes of degree 1.
  [[nodiscard]] int endpoint_count() const;
};

/// Length of a polyline, mm.
double polyline_length(const std::vector<Vector3d>& points);

/// Builds the graph of a curve skeleton (thin_to_curves()). Skeleton voxels with other than two
/// 26-neighbours are node voxels; 26-adjacent node voxels form one node (at their mean
/// position, with their largest radius); runs of two-neighbour voxels between them are branches.
/// Components that are closed loops get one node on the loop. Nodes joining exactly two
/// branches are then merged away.
/// @param[in] skeleton  one component, non-zero = skeleton voxel; its geometry maps to the world.
/// @param[in] radius  vessel radius (mm) per voxel, same grid.
VesselGraph graph_from_skeleton(const Volume<std::uint8_t>& skeleton, const VolumeF& radius);

/// Spur pruning rule: a branch from an end point to a junction is a spur when its length is
/// below max(min_length_mm, radius_factor × the junction's radius).
struct SpurPruning {
  double min_length_mm = 2.0;  ///< spurs shorter than this always go, mm
  double radius_factor = 2.0;  ///< spurs shorter than this × junction radius go (a bump on the
                               ///< wall yields a spur of one to two radii: the junction sits on
                               ///< the axis, the spur reaches into the bump)
};

/// Removes spurs, shortest first and at most one per junction per round, until none is left;
/// nodes left with two branches are merged and isolated nodes dropped.
/// @return the number of spurs removed.
int prune_spurs(VesselGraph& graph, const SpurPruning& rule);

/// Smooths each branch (interior points and radii; ends fixed) by `passes` of the
/// (1/4, 1/2, 1/4) filter, which takes the voxel staircase out of thinned centrelines.
void smooth_branches(VesselGraph& graph, int passes);

/// Resamples each branch at equal arc-length steps of at most `step_mm` (ends kept; radii
/// interpolated linearly).
void resample_branches(VesselGraph& graph, double step_mm);

/// The points + segments + radii form used by the registration: nodes first (point i = node
/// i), then the interior points of each branch in order.
core::Skeleton to_skeleton(const VesselGraph& graph);

}  // namespace brainshift::imaging
