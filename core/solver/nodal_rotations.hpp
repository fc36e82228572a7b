#pragma once
/// @file
/// @brief Nodal rotations for compliance warping: R_n = polar( Σ_{e∋n} V_e R_e ) (volume-weighted
/// average of the adjacent element rotations, re-orthonormalised; SOFA's getRotation, weighted).

#include "core/config.hpp"
#include "core/mesh/tet_mesh.hpp"

#include <vector>

namespace brainshift::core {

/// @param[in] mesh  the rest mesh (volumes as weights).
/// @param[in] element_rotations #T proper rotations.
/// @return #N proper rotations.
std::vector<Matrix3d> nodal_rotations(const TetMesh& mesh,
                                      const std::vector<Matrix3d>& element_rotations);

}  // namespace brainshift::core
