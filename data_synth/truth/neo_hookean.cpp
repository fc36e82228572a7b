#include "data_synth/truth/neo_hookean.hpp"

#include "core/error.hpp"

#include <cmath>

namespace brainshift::data_synth {

NeoHookean NeoHookean::from_youngs(double youngs_modulus, double poisson_ratio) {
  BS_VERIFY(youngs_modulus > 0.0 && poisson_ratio > -1.0 && poisson_ratio < 0.5,
            "neo-Hookean needs E > 0 and nu in (-1, 0.5), got E = "
                << youngs_modulus << " kPa, nu = " << poisson_ratio);
  return {youngs_modulus / (2.0 * (1.0 + poisson_ratio)),
          youngs_modulus / (3.0 * (1.0 - 2.0 * poisson_ratio))};
}

Matrix3d cofactor(const Matrix3d& F) {
  Matrix3d c;
  c.col(0) = F.col(1).cross(F.col(2));
  c.col(1) = F.col(2).cross(F.col(0));
  c.col(2) = F.col(0).cross(F.col(1));
  return c;
}

double NeoHookean::energy(const Matrix3d& F) const {
  const double J = F.determinant();
  return 0.5 * mu * (std::pow(J, -2.0 / 3.0) * F.squaredNorm() - 3.0) +
         0.5 * kappa * (J - 1.0) * (J - 1.0);
}

Matrix3d NeoHookean::first_piola(const Matrix3d& F) const {
  const Matrix3d C = cofactor(F);  // J F^{-T}
  const double J = F.col(0).dot(C.col(0));
  const double I1 = F.squaredNorm();
  const double J23 = std::cbrt(1.0 / (J * J));  // J^{-2/3}
  return mu * J23 * (F - (I1 / (3.0 * J)) * C) + kappa * (J - 1.0) * C;
}

}  // namespace brainshift::data_synth
