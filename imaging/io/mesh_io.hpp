#pragma once
/// @file
/// @brief Tetrahedral meshes in VTK XML unstructured-grid files (.vtu), readable by ParaView and
/// 3D Slicer. Positions in mm, world RAS frame. Per-cell arrays `youngs_modulus` (kPa) and
/// `poisson_ratio`; an optional per-point array `displacement` (mm, 3 components).

#include "core/config.hpp"
#include "core/mesh/tet_mesh.hpp"

#include <filesystem>

namespace brainshift::imaging {

/// Reads a tetrahedral mesh from a .vtu file.
/// @param[in] path  VTK XML unstructured grid with only VTK_TETRA cells, positively oriented.
/// @return the mesh; `youngs_modulus` defaults to 1.5 kPa and `poisson_ratio` to 0.45 where
/// the file lacks these cell arrays. Other arrays are ignored.
/// \throws brainshift::Error, one line naming the file: missing or unreadable file, not a VTK
/// XML unstructured grid, a cell that is not a tetrahedron (its index and type), a material
/// array of the wrong size, or any problem found by core::validate() (NaN coordinates, inverted
/// tetrahedra, unused nodes, bad materials).
core::TetMesh read_tet_mesh(const std::filesystem::path& path);

/// Reads the point array `displacement` (#N×3, mm) of a .vtu file, e.g. a result of
/// write_tet_mesh().
/// \throws brainshift::Error, one line naming the file, when it cannot be read or has no
/// 3-component point array `displacement`.
MatrixX3d read_displacement(const std::filesystem::path& path);

/// Writes the rest mesh, its materials and optionally a nodal displacement to a .vtu file
/// (binary appended data, so values round-trip exactly). The file appears complete or not at
/// all: it is written under a temporary name in the same folder and then renamed.
/// @param[in] path  target file; its folder must exist.
/// @param[in] mesh  rest mesh.
/// @param[in] displacement  #N×3 nodal displacement, mm, written as the point array
/// `displacement`; nullptr: no point array. Not owned; only read during the call.
/// \throws brainshift::Error, one line naming the path, when the folder does not exist or is not
/// writable, or when `displacement` does not have one row per node.
void write_tet_mesh(const std::filesystem::path& path, const core::TetMesh& mesh,
                    const MatrixX3d* displacement = nullptr);

}  // namespace brainshift::imaging
