#pragma once
/// @file
/// @brief Vessel skeleton graphs in VTK XML polydata files (.vtp), readable by ParaView and
/// 3D Slicer: one polyline cell per branch, node points shared by the branches that meet there,
/// positions in mm in the world RAS frame, and a per-point array `radius` (mm).

#include "imaging/vessels/skeleton_graph.hpp"

#include <filesystem>

namespace brainshift::imaging {

/// Writes `graph` to a .vtp file atomically (binary appended data, so values round-trip).
/// \throws brainshift::Error naming the path when its folder does not exist or the write fails.
void write_skeleton_vtp(const std::filesystem::path& path, const VesselGraph& graph);

/// Reads a polyline .vtp file as a graph: each line or polyline cell is a branch; its end
/// points are nodes (cells sharing an end point id meet at one node). Radii come from the point
/// array `radius`, else `MaximumInscribedSphereRadius` (VMTK centerlines), else are 0 (a
/// warning is logged). Points are taken as world RAS mm as they stand.
/// \throws brainshift::Error, one line naming the file: missing, unreadable or not polydata, no
/// line cells, a cell with fewer than 2 points, non-finite coordinates, a radius array of the
/// wrong size.
VesselGraph read_skeleton_vtp(const std::filesystem::path& path);

}  // namespace brainshift::imaging
