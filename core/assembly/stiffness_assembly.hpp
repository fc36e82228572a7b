#pragma once
/// @file
/// @brief Global stiffness assembly.

#include "core/config.hpp"
#include "core/fem/corotational.hpp"

#include <vector>

namespace brainshift::core {

/// Rest stiffness K0 = Σ_e Aᵀ K_e A (3N×3N, symmetric PSD, rigid modes in its null space; mN/mm).
SparseMatrix assemble_rest_stiffness(const CorotationalModel& model);

/// Rotated tangent K(R) = Σ_e Aᵀ R̂_e K_e R̂_eᵀ A (3N×3N), with R̂_e = diag(R_e×4). Used by the
/// exact-compliance reference (refactorised per iteration) and in tests, not on the fast path.
SparseMatrix assemble_rotated_stiffness(const CorotationalModel& model,
                                        const std::vector<Matrix3d>& element_rotations);

}  // namespace brainshift::core
