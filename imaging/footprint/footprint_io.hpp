#pragma once
/// @file
/// @brief Footprint point sets as VTK XML polydata (.vtp): one vertex cell per point, world RAS
/// mm, and the point-data array `normals` (3 components, unit, pointing into the tissue).

#include "core/config.hpp"

#include <filesystem>

namespace brainshift::imaging {

/// Points and their unit normals into the tissue, world RAS mm.
struct FootprintPoints {
  MatrixX3d points;
  MatrixX3d normals;
};

/// Writes the footprint atomically (nothing half-written under `path`).
/// \throws brainshift::Error naming the path: mismatched sizes, non-finite values, or a failed
/// write.
void write_footprint_vtp(const std::filesystem::path& path, const MatrixX3d& points,
                         const MatrixX3d& normals);

/// Reads a footprint .vtp written by write_footprint_vtp() (or any polydata with a 3-component
/// point array `normals`). \throws brainshift::Error naming the file when it is unreadable or
/// has no such array.
FootprintPoints read_footprint_vtp(const std::filesystem::path& path);

}  // namespace brainshift::imaging
