#pragma once
/// @file
/// @brief Compressible (decoupled) neo-Hookean material of the truth model (Joldes et al. 2009,
/// Miller et al. 2012 = seed 003), with strain energy density (kPa = mJ/mm³)
///   W(F) = μ/2 (Ī₁ − 3) + κ/2 (J − 1)²,   J = det F,  Ī₁ = J^{−2/3} tr(Fᵀ F),
/// and first Piola–Kirchhoff stress (kPa)
///   P = ∂W/∂F = μ J^{−2/3} (F − (I₁/3) F^{−T}) + κ J (J − 1) F^{−T}.
/// Its linearisation at F = I is isotropic linear elasticity with shear modulus μ and bulk
/// modulus κ, so μ = E / (2(1 + ν)), κ = E / (3(1 − 2ν)) reproduce the linear model's E and ν.
/// Only defined for J > 0 (the caller detects inverted elements).

#include "core/config.hpp"

namespace brainshift::data_synth {

/// Material constants of one element, kPa.
struct NeoHookean {
  double mu = 0.0;     ///< shear modulus μ, kPa
  double kappa = 0.0;  ///< bulk modulus κ, kPa

  /// From Young's modulus E (kPa) and Poisson ratio ν ∈ (−1, 0.5).
  [[nodiscard]] static NeoHookean from_youngs(double youngs_modulus, double poisson_ratio);
  /// Strain energy density W(F), kPa. \pre det F > 0.
  [[nodiscard]] double energy(const Matrix3d& F) const;
  /// First Piola–Kirchhoff stress P(F) = ∂W/∂F, kPa. \pre det F > 0.
  [[nodiscard]] Matrix3d first_piola(const Matrix3d& F) const;
};

/// Cofactor matrix cof F = J F^{−T} (exists for any F; used to avoid the inverse).
Matrix3d cofactor(const Matrix3d& F);

}  // namespace brainshift::data_synth
