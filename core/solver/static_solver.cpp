#include "core/solver/static_solver.hpp"

#include "core/assembly/stiffness_assembly.hpp"
#include "core/error.hpp"
#include "core/logger.hpp"
#include "core/solver/nodal_rotations.hpp"
#include "core/solver/warped_compliance.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

namespace brainshift::core {

namespace {

/// An increment more than this many times the first one means the iteration is diverging.
constexpr double divergence_growth = 1e3;

/// Largest nodal Euclidean norm of a node-major 3N vector (mm); NaN propagates as +inf.
double max_nodal_norm(const Eigen::VectorXd& v) {
  double m = 0.0;
  for (Eigen::Index i = 0; i + 2 < v.size(); i += 3) {
    const double n = v.segment<3>(i).norm();
    if (!std::isfinite(n)) return std::numeric_limits<double>::infinity();
    m = std::max(m, n);
  }
  return m;
}

/// ‖r_free‖ / ‖total load‖, the total load being max(‖f_ext‖, ‖f_int‖) over all DOFs: at
/// equilibrium f_int carries the reactions of the Dirichlet nodes, so prescribed-displacement
/// problems without body forces still get a meaningful scale. 0 / 0 counts as 0.
double relative_residual(const Eigen::VectorXd& r_free, const Eigen::VectorXd& f_ext,
                         const Eigen::VectorXd& f_int) {
  const double scale = std::max(f_ext.norm(), f_int.norm());
  const double num = r_free.norm();
  return scale > 0.0 ? num / scale : num;
}

/// Empty when the Dirichlet nodes contain three non-collinear nodes (no rigid mode survives in
/// a connected mesh), else the reason.
std::string rigid_mode_issue(const TetMesh& mesh, const std::vector<index_t>& dirichlet_nodes) {
  const double size =
      (mesh.nodes().colwise().maxCoeff() - mesh.nodes().colwise().minCoeff()).norm();
  // Collinearity threshold: area of the triangle relative to size², far above rounding.
  const double area_floor = 1e-10 * size * size;
  const auto describe = [&](const std::string& why) {
    return "the model is under-constrained (" + std::to_string(dirichlet_nodes.size()) +
           " Dirichlet nodes, " + why +
           "): rigid motions are free and K0 is singular; fix at least three non-collinear nodes";
  };
  if (dirichlet_nodes.empty()) return describe("none");
  const Vector3d a = mesh.nodes().row(dirichlet_nodes.front()).transpose();
  index_t far = -1;
  double far_dist = 0.0;
  for (const index_t i : dirichlet_nodes) {
    const double d = (mesh.nodes().row(i).transpose() - a).norm();
    if (d > far_dist) {
      far_dist = d;
      far = i;
    }
  }
  if (far < 0 || far_dist <= 1e-10 * size) return describe("all at one point");
  const Vector3d b = mesh.nodes().row(far).transpose();
  for (const index_t i : dirichlet_nodes) {
    const Vector3d c = mesh.nodes().row(i).transpose();
    if ((b - a).cross(c - a).norm() > area_floor) return {};
  }
  return describe("all on one line");
}

/// Rest positions with the prescribed displacements applied (#N×3, mm).
MatrixX3d initial_positions(const TetMesh& mesh, const DofMap& dofs,
                            const std::vector<PrescribedDisplacement>& prescribed) {
  const index_t n = mesh.num_nodes();
  MatrixX3d x = mesh.nodes();
  for (const PrescribedDisplacement& p : prescribed) {
    BS_VERIFY(p.node >= 0 && p.node < n,
              "prescribed node " << p.node << " is outside [0, " << n << ")");
    BS_VERIFY(dofs.is_fixed_node(p.node),
              "node " << p.node << " has a prescribed displacement but is not a Dirichlet node");
    BS_VERIFY(p.displacement.allFinite(), "prescribed displacement of node "
                                              << p.node
                                              << " is not finite: " << p.displacement.transpose());
    x.row(p.node) = mesh.nodes().row(p.node) + p.displacement.transpose();
  }
  return x;
}

/// Fills the final-state fields of `result` (displacement, residual, inverted elements) at x.
void finish(const CorotationalModel& model, const DofMap& dofs, const MatrixX3d& x,
            const Eigen::VectorXd& f_ext, bool corotational, StaticResult& result) {
  const ElementRotations final_rotations = model.element_rotations(x);
  std::vector<Matrix3d> rotations = final_rotations.rotation;
  if (!corotational) std::fill(rotations.begin(), rotations.end(), Matrix3d::Identity());
  const Eigen::VectorXd f_int = model.internal_force(x, rotations);
  result.final_residual = relative_residual(dofs.restrict(f_ext - f_int), f_ext, f_int);
  result.inverted_elements = final_rotations.inverted_count;
  result.displacement = x - model.mesh().nodes();
  if (result.inverted_elements > 0) {
    result.message += "; " + std::to_string(result.inverted_elements) + " inverted elements";
  }
  logger().debug("static solve: {} after {} iterations, residual {:.3e}, {} inverted elements",
                 to_string(result.status), result.iterations, result.final_residual,
                 result.inverted_elements);
}

}  // namespace

std::string StaticOptions::validate() const {
  std::ostringstream why;
  if (max_iterations < 1) why << "max_iterations must be ≥ 1, got " << max_iterations << "; ";
  if (!(increment_tolerance > 0.0) || !std::isfinite(increment_tolerance)) {
    why << "increment_tolerance must be positive and finite, got " << increment_tolerance << "; ";
  }
  if (!gravity.allFinite()) why << "gravity is not finite: " << gravity.transpose() << "; ";
  if (!(density >= 0.0) || !std::isfinite(density)) {
    why << "density must be non-negative and finite, got " << density << " kg/mm³; ";
  }
  std::string s = why.str();
  if (!s.empty()) s.resize(s.size() - 2);
  return s;
}

std::string to_string(SolveStatus status) {
  switch (status) {
    case SolveStatus::CONVERGED:
      return "converged";
    case SolveStatus::MAX_ITERATIONS:
      return "max iterations";
    case SolveStatus::DIVERGED:
      return "diverged";
    case SolveStatus::FACTOR_FAILED:
      return "factorisation failed";
  }
  BS_UNREACHABLE();
}

StaticSolver::StaticSolver(const TetMesh& mesh, const std::vector<index_t>& dirichlet_nodes)
    : m_model(mesh), m_dofs(mesh.num_nodes(), dirichlet_nodes) {
  if (m_dofs.num_free() == 0) return;  // everything prescribed: nothing to factorise
  m_underconstrained = rigid_mode_issue(mesh, dirichlet_nodes);
  if (!m_underconstrained.empty()) {
    logger().warn("static solver: {}", m_underconstrained);
    return;
  }
  const SparseMatrix K0_ff = m_dofs.restrict(assemble_rest_stiffness(m_model));
  const FactorStatus status = m_factor.compute(K0_ff);
  if (status != FactorStatus::OK) {
    logger().warn(
        "static solver: K0 restricted to {} free DOFs ({} Dirichlet nodes) could not "
        "be factorised: {}",
        m_dofs.num_free(), dirichlet_nodes.size(), m_factor.message());
  }
}

StaticResult StaticSolver::solve(const std::vector<PrescribedDisplacement>& prescribed,
                                 const StaticOptions& options) const {
  const std::string invalid = options.validate();
  BS_VERIFY(invalid.empty(), "invalid static solver options: " << invalid);
  const TetMesh& mesh = m_model.mesh();
  const index_t n = mesh.num_nodes();
  MatrixX3d x = initial_positions(mesh, m_dofs, prescribed);

  StaticResult result;
  const bool has_free = m_dofs.num_free() > 0;
  if (has_free && !m_factor.ok()) {
    result.status = SolveStatus::FACTOR_FAILED;
    result.message = !m_underconstrained.empty()
                         ? m_underconstrained
                         : "K0 on the free DOFs could not be factorised (is the model under-"
                           "constrained? it has " +
                               std::to_string(n - m_dofs.num_free() / 3) +
                               " Dirichlet nodes): " + m_factor.message();
    result.displacement = x - mesh.nodes();
    result.inverted_elements = m_model.element_rotations(x).inverted_count;
    return result;
  }

  const Eigen::VectorXd f_ext = options.gravity.isZero(0.0)
                                    ? Eigen::VectorXd::Zero(3 * n)
                                    : m_model.gravity_force(options.gravity, options.density);
  const std::vector<Matrix3d> identity(static_cast<std::size_t>(mesh.num_tets()),
                                       Matrix3d::Identity());
  WarpedCompliance compliance(m_factor, m_dofs);
  double first_increment = 0.0;
  bool stopped = false;
  for (int it = 1; it <= options.max_iterations && has_free; ++it) {
    // The first iteration is the linear FEM solve (R = I): it already carries any rigid motion
    // prescribed on the boundary into the interior (linear elements reproduce affine fields),
    // whereas the rotations of the starting configuration, with only the boundary moved, are
    // meaningless and can send the iteration astray under large prescribed rotations.
    std::vector<Matrix3d> rotations = identity;
    if (options.corotational && it > 1) {
      rotations = m_model.element_rotations(x).rotation;
      compliance.set_rotations(nodal_rotations(mesh, rotations));
    }
    const Eigen::VectorXd f_int = m_model.internal_force(x, rotations);
    const Eigen::VectorXd r = f_ext - f_int;
    const double residual = relative_residual(m_dofs.restrict(r), f_ext, f_int);
    const Eigen::VectorXd dx = compliance.apply(r);
    const double increment = max_nodal_norm(dx);
    if (!std::isfinite(increment) || (it > 1 && increment > divergence_growth * first_increment)) {
      std::ostringstream msg;
      msg << "diverged at iteration " << it << ": increment " << increment << " mm (first "
          << first_increment << " mm); returning the last finite iterate";
      result.status = SolveStatus::DIVERGED;
      result.message = msg.str();
      stopped = true;
      break;
    }
    if (it == 1) first_increment = increment;
    x += Eigen::Map<const MatrixX3d>(dx.data(), n, 3);
    result.iterations = it;
    result.final_increment = increment;
    result.increment_history.push_back(increment);
    const double scale = std::max(1.0, (x - mesh.nodes()).rowwise().norm().maxCoeff());
    logger().debug(
        "static solve: iteration {} increment {:.3e} mm (tolerance {:.3e} mm), "
        "residual before step {:.3e}",
        it, increment, options.increment_tolerance * scale, residual);
    if (!options.corotational) {
      result.status = SolveStatus::CONVERGED;
      result.message = "linear FEM: one solve with K0";
      stopped = true;
      break;
    }
    if (increment < options.increment_tolerance * scale) {
      result.status = SolveStatus::CONVERGED;
      result.message = "converged in " + std::to_string(it) + " iterations";
      stopped = true;
      break;
    }
  }
  if (!has_free) {
    result.status = SolveStatus::CONVERGED;
    result.message = "every node is a Dirichlet node: nothing to solve";
  } else if (!stopped) {
    result.status = SolveStatus::MAX_ITERATIONS;
    result.message = "reached the cap of " + std::to_string(options.max_iterations) +
                     " iterations; last increment " + std::to_string(result.final_increment) +
                     " mm";
  }

  finish(m_model, m_dofs, x, f_ext, options.corotational, result);
  return result;
}

}  // namespace brainshift::core
