#pragma once
/// @file
/// @brief The node-list and nodal-displacement CSV files of the command line.
///
/// Node list (`--fixed`): header `node`, then one 0-based node id per line.
/// Displacements (`--displace`): header `node,dx,dy,dz`, then one node id and its prescribed
/// displacement (mm, world RAS) per line. Blank lines and surrounding spaces are ignored;
/// Windows line ends are accepted.

#include "core/config.hpp"
#include "core/solver/static_solver.hpp"

#include <filesystem>
#include <string>
#include <vector>

namespace brainshift::imaging {

/// Reads a node-list CSV.
/// @param[in] path  the file.
/// @param[in] num_nodes  when ≥ 0, ids must lie in [0, num_nodes).
/// @return node ids in file order (repeated ids are kept).
/// \throws brainshift::Error, one line naming the file and, for bad content, the line number
/// (missing file, wrong header, a field that is not a non-negative integer, an id out of range).
std::vector<index_t> read_node_list(const std::filesystem::path& path, index_t num_nodes = -1);

/// Reads a nodal-displacement CSV.
/// @param[in] path  the file.
/// @param[in] num_nodes  when ≥ 0, ids must lie in [0, num_nodes).
/// @return one prescribed displacement (mm) per line, in file order.
/// \throws brainshift::Error, one line naming the file and line: missing file, wrong header,
/// wrong field count, a non-numeric or non-finite value, an id out of range, a repeated id.
std::vector<core::PrescribedDisplacement> read_node_displacements(const std::filesystem::path& path,
                                                                  index_t num_nodes = -1);

/// Writes a node-list CSV (atomically: complete or not at all).
/// \throws brainshift::Error naming the path when it cannot be written.
void write_node_list(const std::filesystem::path& path, const std::vector<index_t>& nodes);

/// Writes a nodal-displacement CSV with full double precision (atomically).
/// \throws brainshift::Error naming the path when it cannot be written.
void write_node_displacements(const std::filesystem::path& path,
                              const std::vector<core::PrescribedDisplacement>& displacements);

/// Landmarks: ids (any text without commas) and world RAS positions, mm.
struct Landmarks {
  std::vector<std::string> ids;
  MatrixX3d points;  ///< #L×3
};

/// Reads a landmark CSV with the header `id,x,y,z` (mm, world RAS).
/// \throws brainshift::Error naming the file and line: missing file, wrong header, wrong field
/// count, a non-numeric or non-finite coordinate, a repeated id.
Landmarks read_landmarks(const std::filesystem::path& path);

/// Writes a landmark CSV (`id,x,y,z`, full precision) atomically.
void write_landmarks(const std::filesystem::path& path, const Landmarks& landmarks);

}  // namespace brainshift::imaging
