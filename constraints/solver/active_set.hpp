#pragma once
/// @file
/// @brief Direct active-set solve of the constraint problem of one step (the same laws as
/// pgs.hpp): the rows believed active are solved together, W_AA λ_A = −δ_A, by a dense LDLᵀ;
/// unilateral rows with λ < 0 leave the set, unilateral rows with g < 0 join it, until the set
/// no longer changes (a primal–dual active-set iteration, Hintermüller, Ito & Kunisch 2002).
/// The answer is then handed to projected Gauss–Seidel as a warm start, which verifies it (one
/// sweep when it is exact), finishes it when the set did not settle, and reports the residual.
///
/// Why: PGS converges linearly at a rate set by the conditioning of W; on a few hundred coupled
/// rows (vessel points 2.5 mm apart on a 7 mm mesh) it needs hundreds of sweeps of O(m²) each,
/// while one LDLᵀ of the m×m block is O(m³/3) — at m ≈ 400 that is 5 ms against 40–60 ms.
/// PGS stays the solver for very large row sets and bounded forces (λ_max), and the reference.

#include "constraints/solver/pgs.hpp"

namespace brainshift::constraints {

/// How a step solves for λ.
enum class ConstraintSolver {
  AUTO,         ///< ACTIVE_SET up to `direct_max_rows` rows and without λ_max, else GAUSS_SEIDEL
  ACTIVE_SET,   ///< direct active-set solve, verified by PGS
  GAUSS_SEIDEL  ///< projected block Gauss–Seidel only
};
std::string to_string(ConstraintSolver s);
/// Names of ConstraintSolver in the scene, reports and the command line.
constexpr std::array<core::EnumName<ConstraintSolver>, 3> enum_names(ConstraintSolver /*tag*/) {
  return {{{ConstraintSolver::AUTO, "auto"},
           {ConstraintSolver::ACTIVE_SET, "active_set"},
           {ConstraintSolver::GAUSS_SEIDEL, "gauss_seidel"}}};
}

/// Solves with the chosen method; same contract as solve_pgs().
/// @param[in] direct_max_rows row count above which AUTO uses Gauss–Seidel.
PgsResult solve_constraints(ConstRef<Eigen::MatrixXd> W, ConstRef<Eigen::VectorXd> delta_free,
                            const ConstraintRows& rows, ConstRef<Eigen::VectorXd> warm_start,
                            const PgsOptions& options,
                            ConstraintSolver solver = ConstraintSolver::AUTO,
                            index_t direct_max_rows = 3000);

}  // namespace brainshift::constraints
