#pragma once
/// @file
/// @brief Centreline points of vessels cut by the edge of the ultrasound sector. An ultrasound
/// volume carries signal only inside the probe's sector (a cone under the probe face): outside
/// it the scanner writes exactly 0 (or NaN). A vessel that crosses the sector's side is imaged
/// as a truncated tube, and the centreline of what is left lies inside the sector: deeper and
/// toward the beam axis, by up to the vessel's radius. On the phantoms these points carried a
/// shared bias of +1.0 to +1.5 mm along the beam (RMS 1.5–2.0 mm against 0.5–0.9 mm for the
/// other points; bench/doppler_bias.cpp), which a deformation follows. This file finds the
/// sector and drops the points whose vessel reaches its side. The grid's faces (the probe face
/// among them) are not treated as an edge: on the phantoms a third of the vessel points lie
/// within a radius of the probe face (cortical vessels under the probe), with a smaller bias
/// (+0.3 to +0.8 mm along the beam), and dropping them left too few points for the start.
/// Positions in world RAS mm, distances and radii in mm.

#include "imaging/io/volume.hpp"
#include "imaging/vessels/skeleton_graph.hpp"

#include <cstdint>

namespace brainshift::imaging {

/// What drop_points_at_support_edge() found and did.
struct SupportEdgeResult {
  int dropped = 0;                  ///< branch points dropped (a node counted once)
  bool sector_found = false;        ///< an outside region (a sector mask) was found
  std::int64_t outside_voxels = 0;  ///< voxels of the outside region
};

/// Drops every branch point p of radius r whose distance to the outside region is below
/// r + margin_mm (its vessel reaches the sector's side: its centre there is not measured),
/// cutting the branches there.
///
/// The outside is the set of voxels that are exactly 0 or not finite and 6-connected to a face
/// of the grid through such voxels (the scanner's mask beyond the sector). It counts only when
/// the support it leaves holds at least `min_support_ratio` × `foreground_voxels` voxels: a
/// clean power Doppler whose background inside the sector is also exactly 0 shows no sector
/// (every vessel would touch the "edge"), and then nothing is dropped.
///
/// Runs of fewer than two kept points go, and nodes no branch uses. A kept run that ends where
/// its branch ended keeps that node (junctions stay shared); a run cut inside a branch gets a new
/// end node.
/// @param[in,out] graph  extracted from `image`, world RAS mm.
/// @param[in] image  one component, the volume the graph was extracted from.
/// @param[in] foreground_voxels  voxels at or above the vessel threshold, ≥ 0.
/// @param[in] margin_mm  ≥ 0.
/// @param[in] min_support_ratio  ≥ 1.
/// \throws brainshift::Error for a volume that is not one-component or invalid margins.
SupportEdgeResult drop_points_at_support_edge(VesselGraph& graph, const VolumeF& image,
                                              std::int64_t foreground_voxels, double margin_mm,
                                              double min_support_ratio = 8.0);

}  // namespace brainshift::imaging
