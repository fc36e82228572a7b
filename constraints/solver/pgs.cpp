#include "constraints/solver/pgs.hpp"

#include "core/error.hpp"
#include "core/logger.hpp"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <sstream>

namespace brainshift::constraints {

std::string PgsOptions::validate() const {
  if (max_iterations < 1) return "PGS max_iterations must be ≥ 1";
  if (!(tolerance > 0)) return "PGS tolerance must be > 0";
  if (!(lambda_max >= 0)) return "PGS lambda_max must be ≥ 0 (0 = unbounded)";
  if (stall_window < 2) return "PGS stall_window must be ≥ 2";
  if (active_set_max_changes < 1) return "active_set_max_changes must be ≥ 1";
  return {};
}

std::string to_string(PgsStop stop) {
  switch (stop) {
    case PgsStop::CONVERGED:
      return "converged";
    case PgsStop::NO_ROWS:
      return "no_rows";
    case PgsStop::MAX_ITERATIONS:
      return "max_iterations";
    case PgsStop::STALLED:
      return "stalled";
  }
  BS_UNREACHABLE();
}

namespace {

struct Group {
  index_t begin = 0;
  int size = 0;
  bool unilateral = false;
  Eigen::Matrix3d inverse = Eigen::Matrix3d::Zero();  // pseudo-inverse of the diagonal block
};

/// Pseudo-inverse of a symmetric PSD block (≤ 3×3), dropping eigenvalues ≤ tol.
Eigen::Matrix3d block_pseudo_inverse(const Eigen::MatrixXd& B, double tol) {
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(B);
  Eigen::Matrix3d P = Eigen::Matrix3d::Zero();
  const auto n = B.rows();
  for (Eigen::Index k = 0; k < n; ++k) {
    const double ev = es.eigenvalues()(k);
    if (ev > tol) {
      P.topLeftCorner(n, n) += es.eigenvectors().col(k) * es.eigenvectors().col(k).transpose() / ev;
    }
  }
  return P;
}

double natural_residual(const Eigen::VectorXd& g, const Eigen::VectorXd& lambda,
                        const Eigen::VectorXd& diag, const ConstraintRows& rows,
                        const std::vector<char>& active) {
  double r = 0;
  for (index_t i = 0; i < rows.size(); ++i) {
    if (!active[i]) continue;
    const double ri = rows[i].law == ConstraintLaw::BILATERAL
                          ? std::abs(g[i])
                          : std::abs(std::min(g[i], diag[i] * lambda[i]));
    r = std::max(r, ri);
  }
  return r;
}

/// The rows' groups: contiguous runs of one group id (at most 3 bilateral rows, a unilateral
/// row alone), each with the pseudo-inverse of its diagonal block (inactive rows zeroed).
std::vector<Group> make_groups(ConstRef<Eigen::MatrixXd> W, const ConstraintRows& rows,
                               const std::vector<char>& active, double null_tol) {
  const index_t m = rows.size();
  std::vector<Group> groups;
  for (index_t i = 0; i < m;) {
    Group g;
    g.begin = i;
    g.unilateral = rows[i].law == ConstraintLaw::UNILATERAL;
    index_t j = i;
    while (j < m && rows[j].group == rows[i].group && j - i < 3 && !g.unilateral) ++j;
    if (g.unilateral) j = i + 1;
    g.size = static_cast<int>(j - i);
    // Inactive rows are removed from the block by zeroing them before the pseudo-inverse.
    Eigen::MatrixXd B = W.block(g.begin, g.begin, g.size, g.size);
    for (int a = 0; a < g.size; ++a)
      if (!active[g.begin + a]) {
        B.row(a).setZero();
        B.col(a).setZero();
      }
    g.inverse = block_pseudo_inverse(B, null_tol);
    groups.push_back(g);
    i = j;
  }
  return groups;
}

/// One projected Gauss-Seidel sweep over the groups: λ updated in place, g = δ_free + W λ kept
/// up to date incrementally. Returns the largest change |W_ii Δλ_i|.
double sweep(const std::vector<Group>& groups, ConstRef<Eigen::MatrixXd> W,
             const Eigen::VectorXd& diag, const std::vector<char>& active, double lmax,
             Eigen::VectorXd& lambda, Eigen::VectorXd& g) {
  double change = 0;
  for (const Group& gr : groups) {
    if (gr.unilateral) {
      const index_t i = gr.begin;
      if (!active[i]) continue;
      const double old = lambda[i];
      const double nl = std::clamp(old - g[i] / diag[i], 0.0, lmax);
      const double d = nl - old;
      if (d != 0.0) {
        lambda[i] = nl;
        g.noalias() += W.col(i) * d;
        change = std::max(change, std::abs(diag[i] * d));
      }
      continue;
    }
    const auto gi = g.segment(gr.begin, gr.size);
    Eigen::Vector3d d = Eigen::Vector3d::Zero();
    d.head(gr.size) = -gr.inverse.topLeftCorner(gr.size, gr.size) * gi;
    for (int a = 0; a < gr.size; ++a) {
      const index_t i = gr.begin + a;
      if (!active[i]) {
        d[a] = 0;
        continue;
      }
      const double nl = std::clamp(lambda[i] + d[a], -lmax, lmax);
      d[a] = nl - lambda[i];
      lambda[i] = nl;
      change = std::max(change, std::abs(diag[i] * d[a]));
    }
    g.noalias() += W.middleCols(gr.begin, gr.size) * d.head(gr.size);
  }
  return change;
}

/// The solve's one-line account: the stop, then the ignored and bounded rows.
std::string pgs_message(const PgsResult& res, const PgsOptions& options) {
  std::ostringstream msg;
  if (res.message.empty()) {
    switch (res.stop) {
      case PgsStop::CONVERGED:
        msg << "converged in " << res.iterations << " sweeps";
        break;
      case PgsStop::MAX_ITERATIONS:
        msg << "iteration cap " << options.max_iterations << " reached, residual " << res.residual;
        break;
      case PgsStop::STALLED:
        msg << "no progress for " << options.stall_window << " sweeps at residual " << res.residual
            << ": constraints are inconsistent (antagonistic rows"
            << (res.bounded_rows > 0 ? ", or forces at lambda_max" : "") << ")";
        break;
      case PgsStop::NO_ROWS:
        break;
    }
  } else {
    msg << res.message;
  }
  if (res.ignored_rows > 0)
    msg << "; " << res.ignored_rows << " rows act only on fixed nodes and were ignored";
  if (res.bounded_rows > 0) msg << "; " << res.bounded_rows << " rows at lambda_max";
  return msg.str();
}

}  // namespace

PgsResult solve_pgs(ConstRef<Eigen::MatrixXd> W, ConstRef<Eigen::VectorXd> delta_free,
                    const ConstraintRows& rows, ConstRef<Eigen::VectorXd> warm_start,
                    const PgsOptions& options) {
  const std::string invalid = options.validate();
  BS_VERIFY(invalid.empty(), invalid);
  const index_t m = rows.size();
  BS_VERIFY(W.rows() == m && W.cols() == m,
            "Delassus operator is " << W.rows() << "x" << W.cols() << " for " << m << " rows");
  BS_VERIFY(delta_free.size() == m,
            "delta_free has " << delta_free.size() << " entries for " << m << " rows");
  BS_VERIFY(warm_start.size() == 0 || warm_start.size() == m,
            "warm start has " << warm_start.size() << " entries for " << m << " rows");
  BS_VERIFY(W.allFinite() && delta_free.allFinite(), "PGS input contains NaN or infinity");

  PgsResult res;
  res.lambda = Eigen::VectorXd::Zero(m);
  if (m == 0) {
    res.stop = PgsStop::NO_ROWS;
    res.message = "no constraint rows";
    return res;
  }
  if (warm_start.size() == m && warm_start.allFinite()) res.lambda = warm_start;

  const Eigen::VectorXd diag = W.diagonal();
  const double diag_max = diag.maxCoeff();
  const double null_tol = options.null_row_tolerance * std::max(diag_max, 1e-300);
  std::vector<char> active(static_cast<std::size_t>(m), 1);
  for (index_t i = 0; i < m; ++i)
    if (!(diag[i] > null_tol)) {
      active[i] = 0;
      res.lambda[i] = 0;
      ++res.ignored_rows;
    }

  const std::vector<Group> groups = make_groups(W, rows, active, null_tol);

  const double lmax =
      options.lambda_max > 0 ? options.lambda_max : std::numeric_limits<double>::infinity();
  const double scale = std::max(delta_free.cwiseAbs().maxCoeff(), 1e-9);
  Eigen::VectorXd g = delta_free + W * res.lambda;
  double best = std::numeric_limits<double>::infinity();
  int best_iter = 0;
  res.stop = PgsStop::MAX_ITERATIONS;
  for (int it = 1; it <= options.max_iterations; ++it) {
    const double change = sweep(groups, W, diag, active, lmax, res.lambda, g);
    res.iterations = it;
    res.last_change = change;
    res.residual = natural_residual(g, res.lambda, diag, rows, active) / scale;
    if (!res.lambda.allFinite()) {  // cannot happen for finite PSD W; guard anyway
      res.lambda.setZero();
      g = delta_free;
      res.residual = natural_residual(g, res.lambda, diag, rows, active) / scale;
      res.stop = PgsStop::STALLED;
      res.message = "PGS produced non-finite forces; reset to zero";
      break;
    }
    if (res.residual <= options.tolerance) {
      res.stop = PgsStop::CONVERGED;
      break;
    }
    if (res.residual < 0.99 * best) {
      best = res.residual;
      best_iter = it;
    } else if (it - best_iter >= options.stall_window) {
      res.stop = PgsStop::STALLED;
      break;
    }
  }
  g = delta_free + W * res.lambda;  // refresh against drift of the incremental update
  res.constraint_values = g;
  res.residual = natural_residual(g, res.lambda, diag, rows, active) / scale;
  for (index_t i = 0; i < m; ++i)
    if (std::isfinite(lmax) && std::abs(res.lambda[i]) >= lmax) ++res.bounded_rows;

  res.message = pgs_message(res, options);
  logger().debug("PGS: {}", res.message);
  return res;
}

}  // namespace brainshift::constraints
