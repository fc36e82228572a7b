#pragma once
/// @file
/// @brief Projected (block) Gauss–Seidel for the constraint problem of one static step
/// (seed 002 §3.3.3, "modified Gauss–Seidel"): find λ such that, with g = δ_free + W λ,
///   bilateral rows:  gᵢ = 0,                     λᵢ free;
///   unilateral rows: gᵢ ≥ 0, λᵢ ≥ 0, gᵢ λᵢ = 0;
///   optionally |λᵢ| ≤ λ_max (bounds forces of mis-pairings; breaks the laws where active).
/// Rows of one group (a bilateral point, a sliding line) are updated together by solving their
/// small block exactly (pseudo-inverse, so redundant rows inside a block are harmless); unilateral
/// rows are scalar updates projected on [0, λ_max].
///
/// Stop test: the natural-map residual rᵢ = |gᵢ| (bilateral) or |min(gᵢ, Wᵢᵢ λᵢ)| (unilateral),
/// in mm, max over rows, relative to max(‖δ_free‖∞, 1e-9 mm). This is a statement about the
/// constraint laws, not the size of the last sweep's change (SOFA's test); both are reported.

#include "constraints/rows/constraint_rows.hpp"
#include "core/config.hpp"
#include "core/option_fields.hpp"

#include <cstdint>
#include <string>
#include <vector>

namespace brainshift::constraints {

struct PgsOptions {
  int max_iterations = 500;  ///< sweeps
  double tolerance = 1e-6;   ///< relative natural-map residual
  double lambda_max = 0.0;   ///< bound on |λᵢ| (mN); 0 = unbounded
  int stall_window = 100;    ///< sweeps without a 1 % residual decrease → STALLED
  /// Rows whose Wᵢᵢ ≤ this × max Wⱼⱼ cannot move (they act only on fixed nodes): ignored, λ = 0.
  double null_row_tolerance = 1e-12;
  /// Active-set changes the direct solve (active_set.hpp) may make before it gives up to PGS.
  int active_set_max_changes = 30;
  [[nodiscard]] std::string validate() const;
};

/// The options' names, ranges and documentation (core/option_fields.hpp); in the scene under
/// solver, prefixed pgs_. The bound, stall window and null-row tolerance are constants.
template <class V>
void visit_fields(PgsOptions& o, V&& v) {
  v("max_iterations", o.max_iterations, core::Range{1, 1e6}, "Gauss-Seidel sweeps per step");
  v("tolerance", o.tolerance, core::Range{1e-14, 1}, "relative natural-map residual to stop at");
}

enum class PgsStop {
  CONVERGED,       ///< residual ≤ tolerance
  NO_ROWS,         ///< nothing to solve (λ empty)
  MAX_ITERATIONS,  ///< cap reached before the tolerance
  STALLED,         ///< no progress over stall_window sweeps: the rows are inconsistent
                   ///< (antagonistic pulls, or bounded λ); λ is the last iterate, finite
};
std::string to_string(PgsStop stop);

/// What the direct active-set solve (active_set.hpp) did before PGS verified or finished it.
enum class ActiveSetOutcome : std::uint8_t {
  NOT_USED,      ///< PGS alone (GAUSS_SEIDEL, too many rows, bounded λ, no rows)
  SOLVED,        ///< the set settled and its solve met the laws: PGS verified it
  LDLT_FAILED,   ///< the active block could not be factorised: PGS from the warm start
  NON_FINITE,    ///< the solve gave a non-finite λ: PGS from the warm start
  NO_SETTLING,   ///< the set still changed after active_set_max_changes: PGS from the warm start
  INCONSISTENT,  ///< the set settled but its rows cannot all be met (antagonistic rows): PGS from
                 ///< the warm start
};
std::string to_string(ActiveSetOutcome o);

struct PgsResult {
  Eigen::VectorXd lambda;             ///< #rows, mN
  Eigen::VectorXd constraint_values;  ///< g = δ_free + W λ at the end, mm
  int iterations = 0;
  double residual = 0.0;     ///< final relative natural-map residual
  double last_change = 0.0;  ///< max |Wᵢᵢ Δλᵢ| of the last sweep, mm (SOFA's measure)
  PgsStop stop = PgsStop::NO_ROWS;
  index_t ignored_rows = 0;  ///< rows with Wᵢᵢ ≈ 0 (on fixed nodes only)
  index_t bounded_rows = 0;  ///< rows at |λ| = λ_max at the end
  std::string message;       ///< one line: why it stopped, and any diagnosis
  ActiveSetOutcome active_set = ActiveSetOutcome::NOT_USED;  ///< set by solve_constraints()
  int active_set_changes = 0;                                ///< set changes the direct solve made
};

/// Solves the constraint problem with projected block Gauss–Seidel.
/// @param[in] W  #rows×#rows Delassus operator (symmetric PSD, mm/mN).
/// @param[in] delta_free  constraint values after the free motion, #rows (mm).
/// @param[in] rows  laws and groups (groups contiguous).
/// @param[in] warm_start  initial λ (#rows) or empty for zero.
/// \throws brainshift::Error on inconsistent sizes or non-finite input.
PgsResult solve_pgs(ConstRef<Eigen::MatrixXd> W, ConstRef<Eigen::VectorXd> delta_free,
                    const ConstraintRows& rows, ConstRef<Eigen::VectorXd> warm_start,
                    const PgsOptions& options = {});

}  // namespace brainshift::constraints
