#pragma once
/// @file
/// @brief Rotation extraction for the corotational formulation.

#include "core/config.hpp"

namespace brainshift::core {

/// Rotation R of the polar decomposition F = R S, computed from the SVD F = U Σ Vᵀ.
/// When det F ≤ 0 (inverted or flat element) the column of U of the smallest singular value is
/// negated, so R = U' Vᵀ is always a proper rotation (det R = +1) and the element is pushed back
/// towards its rest orientation, never into a stable inverted state.
/// @param[in] F  deformation gradient (3×3, dimensionless); must be finite.
/// @param[out] inverted  if not null, set to true when det F ≤ 0.
Matrix3d rotation_from_deformation_gradient(const Matrix3d& F, bool* inverted = nullptr);

/// The proper rotation nearest to M in the Frobenius norm (same sign fix as above). Used to
/// re-orthonormalise averaged rotations.
Matrix3d nearest_rotation(const Matrix3d& M);

}  // namespace brainshift::core
