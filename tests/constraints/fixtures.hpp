#pragma once
/// @file
/// @brief Shared scenes for the constraint tests: small box beams fixed at their base.

#include "constraints/rows/constraint_rows.hpp"
#include "core/mesh/tet_mesh.hpp"
#include "data_synth/geometry/structured_mesh.hpp"

#include <vector>

namespace brainshift::tests {

/// Nodes with z ≤ z_max + 1e-9 (mm).
inline std::vector<index_t> nodes_below(const core::TetMesh& mesh, double z_max) {
  std::vector<index_t> out;
  for (index_t i = 0; i < mesh.num_nodes(); ++i)
    if (mesh.nodes()(i, 2) <= z_max + 1e-9) out.push_back(i);
  return out;
}

/// Nodes with z ≥ z_min − 1e-9 (mm).
inline std::vector<index_t> nodes_above(const core::TetMesh& mesh, double z_min) {
  std::vector<index_t> out;
  for (index_t i = 0; i < mesh.num_nodes(); ++i)
    if (mesh.nodes()(i, 2) >= z_min - 1e-9) out.push_back(i);
  return out;
}

/// Stencil of a single node.
inline constraints::Stencil node_stencil(index_t node) {
  constraints::Stencil s;
  s.add(node, 1.0);
  return s;
}

/// All nodes, for the dense compliance block of small test meshes.
inline std::vector<index_t> all_nodes(const core::TetMesh& mesh) {
  std::vector<index_t> v(static_cast<std::size_t>(mesh.num_nodes()));
  for (index_t i = 0; i < mesh.num_nodes(); ++i) v[i] = i;
  return v;
}

}  // namespace brainshift::tests
