#include "constraints/solver/active_set.hpp"

#include "core/error.hpp"
#include "core/logger.hpp"

#include <Eigen/Cholesky>

#include <cmath>
#include <vector>

namespace brainshift::constraints {
namespace {

/// λ from the active-set iteration; empty (with the reason in `outcome`) when it failed.
Eigen::VectorXd active_set_lambda(ConstRef<Eigen::MatrixXd> W, ConstRef<Eigen::VectorXd> delta,
                                  const ConstraintRows& rows, ConstRef<Eigen::VectorXd> warm,
                                  const PgsOptions& options, ActiveSetOutcome& outcome,
                                  int& changes) {
  const index_t m = rows.size();
  const double diag_max = W.diagonal().maxCoeff();
  const double null_tol = options.null_row_tolerance * std::max(diag_max, 1e-300);
  const double g_tol = options.tolerance * std::max(delta.cwiseAbs().maxCoeff(), 1e-9);
  std::vector<char> in(static_cast<std::size_t>(m), 0);
  for (index_t i = 0; i < m; ++i) {
    if (!(W(i, i) > null_tol)) continue;  // acts on fixed nodes only: λ = 0
    in[i] = rows[i].law == ConstraintLaw::BILATERAL || delta[i] < 0 ||
            (warm.size() == m && warm[i] > 0);
  }
  Eigen::VectorXd lambda = Eigen::VectorXd::Zero(m);
  changes = 0;
  for (int round = 0; round <= options.active_set_max_changes; ++round) {
    std::vector<index_t> A;
    for (index_t i = 0; i < m; ++i)
      if (in[i]) A.push_back(i);
    const auto n = static_cast<Eigen::Index>(A.size());
    Eigen::MatrixXd WA(n, n);
    Eigen::VectorXd rhs(n);
    for (Eigen::Index a = 0; a < n; ++a) {
      rhs[a] = -delta[A[a]];
      for (Eigen::Index b = 0; b < n; ++b) WA(a, b) = W(A[a], A[b]);
      WA(a, a) += 1e-12 * diag_max;  // semidefinite W (redundant hard rows): minimum-norm-like λ
    }
    const Eigen::LDLT<Eigen::MatrixXd> ldlt(WA);
    if (ldlt.info() != Eigen::Success) {
      outcome = ActiveSetOutcome::LDLT_FAILED;
      return {};
    }
    const Eigen::VectorXd lA = ldlt.solve(rhs);
    if (!lA.allFinite()) {
      outcome = ActiveSetOutcome::NON_FINITE;
      return {};
    }
    lambda.setZero();
    for (Eigen::Index a = 0; a < n; ++a) lambda[A[a]] = lA[a];
    const Eigen::VectorXd g = delta + W * lambda;
    bool changed = false;
    for (index_t i = 0; i < m; ++i) {
      if (rows[i].law != ConstraintLaw::UNILATERAL || !(W(i, i) > null_tol)) continue;
      if (in[i] && lambda[i] < 0)
        in[i] = 0, changed = true;
      else if (!in[i] && g[i] < -g_tol)
        in[i] = 1, changed = true;
    }
    if (!changed) {
      // An inconsistent active set (two rows pulling one point apart) has no exact solution:
      // the regularised solve then leaves a residual on the active rows. Let PGS diagnose it.
      for (index_t i = 0; i < m; ++i)
        if (in[i] && std::abs(g[i]) > 10 * g_tol) {
          outcome = ActiveSetOutcome::INCONSISTENT;
          return {};
        }
      outcome = ActiveSetOutcome::SOLVED;
      return lambda;
    }
    ++changes;
  }
  outcome = ActiveSetOutcome::NO_SETTLING;
  return {};
}

}  // namespace

std::string to_string(ActiveSetOutcome o) {
  switch (o) {
    case ActiveSetOutcome::NOT_USED:
      return "not_used";
    case ActiveSetOutcome::SOLVED:
      return "solved";
    case ActiveSetOutcome::LDLT_FAILED:
      return "ldlt_failed";
    case ActiveSetOutcome::NON_FINITE:
      return "non_finite";
    case ActiveSetOutcome::NO_SETTLING:
      return "no_settling";
    case ActiveSetOutcome::INCONSISTENT:
      return "inconsistent";
  }
  BS_UNREACHABLE();
}

std::string to_string(ConstraintSolver s) {
  return core::enum_to_string(s);  // the option table's names (visit_fields)
}

PgsResult solve_constraints(ConstRef<Eigen::MatrixXd> W, ConstRef<Eigen::VectorXd> delta_free,
                            const ConstraintRows& rows, ConstRef<Eigen::VectorXd> warm_start,
                            const PgsOptions& options, ConstraintSolver solver,
                            index_t direct_max_rows) {
  const bool direct = solver == ConstraintSolver::ACTIVE_SET ||
                      (solver == ConstraintSolver::AUTO && rows.size() <= direct_max_rows &&
                       options.lambda_max <= 0);
  if (!direct || rows.empty() || W.rows() != rows.size() || delta_free.size() != rows.size() ||
      !W.allFinite() || !delta_free.allFinite())
    return solve_pgs(W, delta_free, rows, warm_start, options);  // (solve_pgs checks the inputs)
  ActiveSetOutcome outcome = ActiveSetOutcome::NOT_USED;
  int changes = 0;
  const Eigen::VectorXd lambda =
      active_set_lambda(W, delta_free, rows, warm_start, options, outcome, changes);
  PgsResult res;
  if (lambda.size() == 0) {
    logger().debug("active set: {} after {} changes; projected Gauss-Seidel from the warm start",
                   to_string(outcome), changes);
    res = solve_pgs(W, delta_free, rows, warm_start, options);
  } else {
    res = solve_pgs(W, delta_free, rows, lambda, options);
  }
  res.active_set = outcome;
  res.active_set_changes = changes;
  return res;
}

}  // namespace brainshift::constraints
