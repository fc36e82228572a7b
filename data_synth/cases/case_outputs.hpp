#pragma once
/// @file
/// @brief The phantom cases' truth files: landmark CSVs (`id,x,y,z`, mm, world RAS) and triangle
/// surfaces (.vtp, world RAS mm) through imaging's readers and writers, plus the surface of a
/// labelled region of the truth mesh (e.g. the ventricles, for Hausdorff distances).

#include "core/config.hpp"
#include "core/mesh/boundary.hpp"
#include "core/mesh/tet_mesh.hpp"

#include <cstdint>
#include <filesystem>
#include <vector>

namespace brainshift::data_synth {

/// Writes `id,x,y,z` with id = 0, 1, … and full double precision, atomically.
/// \throws brainshift::Error naming the path when it cannot be written.
void write_landmarks_csv(const std::filesystem::path& path, const std::vector<Vector3d>& points);

/// Reads a file written by write_landmarks_csv() (header `id,x,y,z`), in file order.
/// \throws brainshift::Error naming the file and line on a missing file or bad content.
std::vector<Vector3d> read_landmarks_csv(const std::filesystem::path& path);

/// The boundary of the tetrahedra carrying `label`: vertices are mesh nodes (node_of_vertex),
/// triangles outward from the region.
core::BoundarySurface region_surface(const core::TetMesh& mesh,
                                     const std::vector<std::uint8_t>& tet_labels,
                                     std::uint8_t label);

/// Writes a triangle surface (#V×3 vertices in mm, #F×3 faces) as VTK XML polydata (imaging's
/// write_surface_vtp), atomically. \throws brainshift::Error naming the path on failure.
void write_surface_vtp(const std::filesystem::path& path, ConstRef<MatrixX3d> vertices,
                       const core::TriangleMatrix& faces);

}  // namespace brainshift::data_synth
