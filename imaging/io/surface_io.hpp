#pragma once
/// @file
/// @brief Triangle surfaces (collision surface, dura, ventricles) in VTK XML polydata files
/// (.vtp), readable by ParaView and 3D Slicer. Positions in mm, world RAS frame.

#include "core/geometry/skeleton.hpp"

#include <filesystem>

namespace brainshift::imaging {

/// Writes the surface atomically (binary appended data, so coordinates round-trip exactly).
/// \throws brainshift::Error naming the path when the folder does not exist or the write fails,
/// or when a triangle indexes a vertex that does not exist.
void write_surface_vtp(const std::filesystem::path& path, const core::SurfaceMesh& surface);

/// Reads the triangles of a .vtp file (polygon cells with 3 points; triangle strips are split).
/// \throws brainshift::Error, one line naming the file: missing, unreadable, not polydata, no
/// triangles, a polygon that is not a triangle (its index and size), non-finite coordinates.
core::SurfaceMesh read_surface_vtp(const std::filesystem::path& path);

}  // namespace brainshift::imaging
