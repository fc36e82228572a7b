#include "data_synth/truth/tled_solver.hpp"

#include "core/error.hpp"
#include "core/fem/linear_tet.hpp"
#include "core/logger.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

namespace brainshift::data_synth {
namespace {

/// Step parameters of the damped central-difference scheme for eigenvalue bounds [lo, hi].
struct Damping {
  double alpha = 0.0, beta = 0.0;
  static Damping optimal(double lo, double hi) {
    const double s = std::sqrt(hi) + std::sqrt(lo), d = std::sqrt(hi) - std::sqrt(lo);
    return {4.0 / (s * s), (d * d) / (s * s)};
  }
  /// Spectral radius of the two-step recurrence for the mode with eigenvalue lambda.
  [[nodiscard]] double rate(double lambda) const {
    const double b = 1.0 + beta - alpha * lambda, disc = b * b - 4.0 * beta;
    if (disc <= 0.0) return std::sqrt(beta);
    return 0.5 * (std::abs(b) + std::sqrt(disc));
  }
};

/// Per-node mask of prescribed components and their final values.
struct Constraints {
  std::vector<std::array<bool, 3>> fixed;
  MatrixX3d value;
};

Constraints gather_constraints(const TledProblem& p, index_t n) {
  Constraints c{std::vector<std::array<bool, 3>>(std::size_t(n), {false, false, false}),
                MatrixX3d::Zero(n, 3)};
  for (const NodeConstraint& nc : p.constraints) {
    BS_VERIFY(nc.node >= 0 && nc.node < n,
              "constraint on node " << nc.node << " outside [0, " << n << ")");
    BS_VERIFY(nc.displacement.allFinite(), "constraint on node " << nc.node << " is not finite");
    for (int a = 0; a < 3; ++a)
      if (nc.fixed[std::size_t(a)]) {
        c.fixed[std::size_t(nc.node)][std::size_t(a)] = true;
        c.value(nc.node, a) = nc.displacement(a);
      }
  }
  return c;
}

/// Kinematic frictionless contact: puts escaped candidates back on the skull and removes the
/// outward normal part of their increment (by moving u_prev). Returns how many were projected.
index_t enforce_contact(const SkullContact& sc, const std::vector<index_t>& candidates,
                        const MatrixX3d& X, const MatrixX3d& u, MatrixX3d& u_next,
                        MatrixX3d& u_prev_out) {
  index_t count = 0;
  for (const index_t i : candidates) {
    const Vector3d x = X.row(i).transpose() + u_next.row(i).transpose();
    Vector3d q, n;
    if (sc.hull) {
      const double rest = std::max(0.0, sc.hull->value(X.row(i).transpose()));
      if (sc.hull->value(x) <= rest) continue;
      q = sc.hull->closest_point(x, rest);
      n = sc.hull->normal(q);
    } else {
      if (sc.skull.level(x) <= 1.0) continue;
      q = sc.skull.closest_point(x);
      n = sc.skull.normal(q);
    }
    if (sc.opening_radius > 0.0 && (q - sc.opening_centre).norm() < sc.opening_radius) continue;
    u_next.row(i) = (q - X.row(i).transpose()).transpose();
    const Vector3d d = (u_next.row(i) - u.row(i)).transpose();
    const double dn = d.dot(n);
    // Velocity for the next step is u_next − u_prev_out: keep only its tangential part.
    u_prev_out.row(i) = u_next.row(i) - (dn > 0.0 ? Vector3d(d - dn * n) : d).transpose();
    ++count;
  }
  return count;
}

double max_row_norm(const MatrixX3d& m) {
  return m.rows() == 0 ? 0.0 : m.rowwise().norm().maxCoeff();
}

}  // namespace

std::string TledOptions::validate() const {
  std::ostringstream s;
  if (max_iterations < 1)
    s << "max_iterations must be >= 1, got " << max_iterations;
  else if (!(error_tolerance > 0.0))
    s << "error_tolerance must be positive, got " << error_tolerance;
  else if (ramp_iterations < 1)
    s << "ramp_iterations must be >= 1, got " << ramp_iterations;
  else if (!(stiffness_safety >= 1.0))
    s << "stiffness_safety must be >= 1, got " << stiffness_safety;
  else if (damping_update_interval < 1)
    s << "damping_update_interval must be >= 1";
  else if (rate_window < 2)
    s << "rate_window must be >= 2, got " << rate_window;
  else if (converged_steps < 1)
    s << "converged_steps must be >= 1, got " << converged_steps;
  else if (!(divergence_displacement > 0.0))
    s << "divergence_displacement must be positive";
  return s.str();
}

std::string to_string(TledStatus status) {
  switch (status) {
    case TledStatus::CONVERGED:
      return "converged";
    case TledStatus::MAX_ITERATIONS:
      return "iteration cap reached";
    case TledStatus::DIVERGED:
      return "diverged";
  }
  BS_UNREACHABLE();
}

TledSolver::TledSolver(const core::TetMesh& mesh)
    : m_num_nodes(mesh.num_nodes()), m_rest(mesh.nodes()), m_tets(mesh.tets()) {
  core::validate(mesh, "TLED mesh");
  const auto nt = std::size_t(mesh.num_tets());
  m_grad.resize(nt);
  m_volume.resize(nt);
  m_material.resize(nt);
  m_mass = Eigen::VectorXd::Zero(m_num_nodes);
  Eigen::MatrixXd row_sums = Eigen::MatrixXd::Zero(m_num_nodes, 3);
  for (index_t t = 0; t < mesh.num_tets(); ++t) {
    const core::TetShape shape = core::tet_shape(mesh.tet_nodes(t));
    const double E = mesh.youngs_modulus()(t), nu = mesh.poisson_ratio()(t);
    m_grad[std::size_t(t)] = shape.grad.transpose();
    m_volume[std::size_t(t)] = shape.volume;
    m_material[std::size_t(t)] = NeoHookean::from_youngs(E, nu);
    const Matrix12d K = core::linear_tet_stiffness(shape, E, nu);
    const Vector12d abs_rows = K.cwiseAbs().rowwise().sum();
    for (int a = 0; a < 4; ++a)
      for (int c = 0; c < 3; ++c) row_sums(m_tets(t, a), c) += abs_rows(3 * a + c);
  }
  // Gershgorin: λ_max(M⁻¹K₀) ≤ max_i rowsum_i / m_i = 1.
  m_mass = row_sums.rowwise().maxCoeff();
}

double TledSolver::add_internal_force(const MatrixX3d& u, MatrixX3d& f) const {
  double min_j = std::numeric_limits<double>::infinity();
  Eigen::Matrix<double, 3, 4> ue;
  for (std::size_t t = 0; t < m_grad.size(); ++t) {
    const auto e = Eigen::Index(t);
    for (int a = 0; a < 4; ++a) ue.col(a) = u.row(m_tets(e, a)).transpose();
    const Matrix3d F = Matrix3d::Identity() + ue * m_grad[t].transpose();
    const double J = F.determinant();
    min_j = std::min(min_j, J);
    if (!(J > 0.0)) {  // inverted: poison the forces so the caller sees it
      f.row(m_tets(e, 0)).setConstant(std::numeric_limits<double>::quiet_NaN());
      continue;
    }
    const Eigen::Matrix<double, 3, 4> fe = m_volume[t] * m_material[t].first_piola(F) * m_grad[t];
    for (int a = 0; a < 4; ++a) f.row(m_tets(e, a)) += fe.col(a).transpose();
  }
  return min_j;
}

MatrixX3d TledSolver::internal_force(ConstRef<MatrixX3d> u, double* min_jacobian) const {
  BS_VERIFY(u.rows() == m_num_nodes,
            "displacement has " << u.rows() << " rows, mesh has " << m_num_nodes << " nodes");
  MatrixX3d f = MatrixX3d::Zero(m_num_nodes, 3);
  const double j = add_internal_force(MatrixX3d(u), f);
  if (min_jacobian) *min_jacobian = j;
  return f;
}

double TledSolver::strain_energy(ConstRef<MatrixX3d> u) const {
  BS_VERIFY(u.rows() == m_num_nodes,
            "displacement has " << u.rows() << " rows, mesh has " << m_num_nodes << " nodes");
  double psi = 0.0;
  Eigen::Matrix<double, 3, 4> ue;
  for (std::size_t t = 0; t < m_grad.size(); ++t) {
    for (int a = 0; a < 4; ++a) ue.col(a) = u.row(m_tets(Eigen::Index(t), a)).transpose();
    const Matrix3d F = Matrix3d::Identity() + ue * m_grad[t].transpose();
    if (!(F.determinant() > 0.0)) return std::numeric_limits<double>::infinity();
    psi += m_volume[t] * m_material[t].energy(F);
  }
  return psi;
}

namespace {

/// Error estimate of dynamic relaxation from the increment history (mm).
struct ErrorEstimate {
  double rate = 0.0;
  double error = 0.0;
};

ErrorEstimate estimate_error(const std::vector<double>& increments, int window, double theory) {
  const double last = increments.back();
  double rate = theory;
  if (int(increments.size()) > window) {
    const double old = increments[increments.size() - 1 - std::size_t(window)];
    const double observed = old > 0.0 ? std::pow(last / old, 1.0 / window) : 0.0;
    rate = std::max(rate, std::min(observed, 1.0 - 1e-12));
  }
  return {rate, last == 0.0 ? 0.0 : rate / (1.0 - rate) * last};
}

}  // namespace

TledResult TledSolver::solve(const TledProblem& p, const TledOptions& o) const {
  const std::string bad = o.validate();
  BS_VERIFY(bad.empty(), "invalid TLED options: " << bad);
  const index_t n = m_num_nodes;
  BS_VERIFY(
      p.external_force.rows() == 0 || p.external_force.rows() == n,
      "external force has " << p.external_force.rows() << " rows, mesh has " << n << " nodes");
  BS_VERIFY(p.external_force.allFinite(), "external force is not finite");
  const MatrixX3d f_ext = p.external_force.rows() == n ? p.external_force : MatrixX3d::Zero(n, 3);
  const Constraints cons = gather_constraints(p, n);
  std::vector<index_t> candidates;
  if (p.contact) {
    candidates = p.contact->candidate_nodes;
    for (const index_t i : candidates)
      BS_VERIFY(i >= 0 && i < n, "contact candidate " << i << " outside [0, " << n << ")");
    if (candidates.empty())
      for (index_t i = 0; i < n; ++i) candidates.push_back(i);
  }
  const Eigen::ArrayXd inv_mass = m_mass.array().inverse();
  const double lambda_max = o.stiffness_safety;
  double lambda_min = 1e-4 * lambda_max;  // first guess, re-estimated below
  Damping damping = Damping::optimal(lambda_min, lambda_max);

  MatrixX3d u_prev = MatrixX3d::Zero(n, 3), u = u_prev, u_next = u_prev, f = u_prev,
            f_prev = u_prev;
  std::vector<double> increments;
  TledResult r;
  auto finish = [&](TledStatus status, const std::string& message, const MatrixX3d& last) {
    r.status = status;
    r.message = message;
    r.displacement = last;
    r.max_displacement = max_row_norm(last);
    r.lambda_min = lambda_min;
    return r;
  };
  int streak = 0;
  for (int it = 1; it <= o.max_iterations; ++it) {
    r.iterations = it;
    const double s = std::min(1.0, double(it) / o.ramp_iterations);
    f.setZero();
    r.min_jacobian = add_internal_force(u, f);
    if (!(r.min_jacobian > 0.0) || !f.allFinite()) {
      std::ostringstream m;
      m << "element inverted or force not finite at step " << it << " (min det F " << r.min_jacobian
        << ")";
      return finish(TledStatus::DIVERGED, m.str(), u);
    }
    if (it > o.ramp_iterations && it % o.damping_update_interval == 0) {
      // Rayleigh quotient of the last increment: Δuᵀ Δf_int / Δuᵀ M Δu → λ_min (Joldes et al.).
      const MatrixX3d du = u - u_prev;
      const double num = du.cwiseProduct(f - f_prev).sum();
      const double den = (du.rowwise().squaredNorm().array() * m_mass.array()).sum();
      if (num > 0.0 && den > 0.0) {
        lambda_min = std::clamp(num / den, 1e-12 * lambda_max, 0.25 * lambda_max);
        damping = Damping::optimal(lambda_min, lambda_max);
      }
    }
    u_next = u + damping.beta * (u - u_prev) +
             damping.alpha * ((s * f_ext - f).array().colwise() * inv_mass).matrix();
    for (index_t i = 0; i < n; ++i)
      for (int c = 0; c < 3; ++c)
        if (cons.fixed[std::size_t(i)][std::size_t(c)]) u_next(i, c) = s * cons.value(i, c);
    u_prev.swap(u);  // u_prev = current iterate
    if (p.contact)
      r.contact_nodes = enforce_contact(*p.contact, candidates, m_rest, u_prev, u_next, u_prev);
    if (!u_next.allFinite() || max_row_norm(u_next) > o.divergence_displacement) {
      std::ostringstream m;
      m << "displacement not finite or beyond " << o.divergence_displacement << " mm at step "
        << it;
      return finish(TledStatus::DIVERGED, m.str(), u_prev);
    }
    u.swap(u_next);
    f_prev.swap(f);
    increments.push_back(max_row_norm(u - u_prev));
    if (it <= o.ramp_iterations) continue;
    const ErrorEstimate e = estimate_error(increments, o.rate_window, damping.rate(lambda_min));
    r.estimated_error = e.error;
    r.convergence_rate = e.rate;
    streak = e.error < o.error_tolerance ? streak + 1 : 0;
    if (it % 2000 == 0)
      logger().debug(
          "TLED step {}: increment {:.3e} mm, error {:.3e} mm, rate {:.6f}, lambda_min {:.3e}", it,
          increments.back(), e.error, e.rate, lambda_min);
    if (streak >= o.converged_steps) {
      std::ostringstream m;
      m << "converged in " << it << " steps, estimated error " << e.error << " mm";
      return finish(TledStatus::CONVERGED, m.str(), u);
    }
  }
  std::ostringstream m;
  m << "iteration cap " << o.max_iterations << " reached, estimated error " << r.estimated_error
    << " mm";
  return finish(TledStatus::MAX_ITERATIONS, m.str(), u);
}

}  // namespace brainshift::data_synth
