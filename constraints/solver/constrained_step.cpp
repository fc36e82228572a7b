#include "constraints/solver/constrained_step.hpp"

#include "core/assembly/stiffness_assembly.hpp"
#include "core/error.hpp"
#include "core/logger.hpp"
#include "core/solver/nodal_rotations.hpp"
#include "core/timing.hpp"

#include <algorithm>

namespace brainshift::constraints {
namespace {
using core::Clock;
using core::seconds_since;

/// Wᵢᵢ += compliance_ratio[set of row i] · median(diag W).
/// Returns median(diag W), the unit of the ratios.
double add_row_compliance(Eigen::MatrixXd& W, const ConstraintRows& rows,
                          const std::array<double, num_constraint_sets>& ratio) {
  if (W.rows() == 0) return 0.0;
  Eigen::VectorXd d = W.diagonal();
  std::nth_element(d.data(), d.data() + d.size() / 2, d.data() + d.size());
  const double median = d[d.size() / 2];
  if (std::all_of(ratio.begin(), ratio.end(), [](double r) { return r == 0.0; })) return median;
  for (index_t i = 0; i < rows.size(); ++i)
    W(i, i) += ratio[static_cast<std::size_t>(rows[i].set)] * median;
  return median;
}
}  // namespace

std::string to_string(Mechanics m) {
  return core::enum_to_string(m);  // the option table's names (visit_fields)
}

ConstrainedModel::ConstrainedModel(const core::TetMesh& mesh,
                                   const std::vector<index_t>& fixed_nodes,
                                   std::vector<index_t> block_nodes,
                                   const ComplianceOptions& compliance)
    : m_model(mesh),
      m_dofs(mesh.num_nodes(), fixed_nodes),
      m_factor(std::make_unique<core::CholmodFactor>()) {
  m_K0 = core::assemble_rest_stiffness(m_model);
  const SparseMatrix K_ff = m_dofs.restrict(m_K0);
  const auto status = m_factor->compute(K_ff);
  BS_VERIFY(status == core::FactorStatus::OK,
            "rest stiffness cannot be factorised ("
                << m_factor->message()
                << "): fix at least 3 non-collinear nodes so the model cannot move rigidly");
  m_compliance =
      std::make_unique<ComplianceOperator>(*m_factor, m_dofs, std::move(block_nodes), compliance,
                                           stiffness_fingerprint(mesh, fixed_nodes), &K_ff);
}

StepResult ConstrainedModel::step(ConstRef<MatrixX3d> x, const ConstraintRows& rows,
                                  const StepOptions& options,
                                  ConstRef<Eigen::VectorXd> warm_start) const {
  const index_t n = m_model.mesh().num_nodes();
  BS_VERIFY(x.rows() == n, "positions have " << x.rows() << " rows for " << n << " nodes");
  StepResult res;
  auto t0 = Clock::now();

  // Free motion.
  Eigen::VectorXd f_int;
  std::unique_ptr<core::CholmodFactor> exact_factor;  // EXACT only
  std::unique_ptr<ComplianceOperator> exact;
  std::vector<Matrix3d>
      rotations;  // nodal; empty = identity (LINEAR, UNWARPED, EXACT's own operator)
  if (options.mechanics == Mechanics::LINEAR) {
    const MatrixX3d u = x - (options.rest ? options.rest->nodes : m_model.mesh().nodes());
    f_int = m_K0 * Eigen::Map<const Eigen::VectorXd>(u.data(), 3 * n);
  } else {
    const core::ElementRotations er = m_model.element_rotations(x, options.rest.get());
    res.inverted_elements = er.inverted_count;
    f_int = m_model.internal_force(x, er.rotation, options.rest.get());
    if (options.mechanics == Mechanics::WARPED)
      rotations = core::nodal_rotations(m_model.mesh(), er.rotation);
    if (options.mechanics == Mechanics::EXACT) {
      exact_factor = std::make_unique<core::CholmodFactor>();
      const auto status = exact_factor->compute(
          m_dofs.restrict(core::assemble_rotated_stiffness(m_model, er.rotation)));
      BS_VERIFY(status == core::FactorStatus::OK,
                "exact tangent cannot be factorised: " << exact_factor->message());
      ComplianceOptions sparse;
      sparse.strategy = ComplianceStrategy::SPARSE_SOLVE;
      exact = std::make_unique<ComplianceOperator>(*exact_factor, m_dofs, std::vector<index_t>{},
                                                   sparse);
    }
  }
  const ComplianceOperator& C = exact ? *exact : *m_compliance;
  Eigen::VectorXd f = -f_int;
  if (!options.gravity.isZero()) f += m_model.gravity_force(options.gravity, options.density);
  const SparseMatrix H = rows.empty() ? SparseMatrix() : rows.jacobian(n);
  const Eigen::VectorXd dx_free = C.apply(f, rotations);
  res.seconds_free_motion = seconds_since(t0);

  std::string diag;
  auto note = [&diag](const std::string& m) { diag += (diag.empty() ? "" : "; ") + m; };
  Eigen::VectorXd dx = dx_free;
  if (!rows.empty()) {
    t0 = Clock::now();
    const Eigen::VectorXd delta_free = rows.violations() + H * dx_free;
    Eigen::MatrixXd W = C.delassus(H, rotations, &res.delassus_fallback);
    if (options.keep_system) {
      res.delassus = W;
      res.delta_free = delta_free;
    }
    res.compliance_scale = add_row_compliance(W, rows, options.compliance_ratio);
    res.seconds_delassus = seconds_since(t0);

    t0 = Clock::now();
    res.pgs = solve_constraints(W, delta_free, rows, warm_start, options.pgs, options.solver);
    res.lambda = res.pgs.lambda;
    res.seconds_pgs = seconds_since(t0);

    t0 = Clock::now();
    dx += C.apply(H.transpose() * res.lambda, rotations);
    res.seconds_correction = seconds_since(t0);
  } else {
    res.pgs.message = "no constraint rows";
  }
  if (!dx.allFinite()) {
    dx.setZero();
    res.finite = false;
    note("the increment was not finite (diverging iteration); step rejected");
  }
  {
    const double step = Eigen::Map<const MatrixX3d>(dx.data(), n, 3).rowwise().norm().maxCoeff();
    res.uncut_increment = step;
    if (options.max_increment > 0 && step > options.max_increment) {
      dx *= options.max_increment / step;
      res.limited = true;
    }
  }
  res.x = x;
  Eigen::Map<Eigen::VectorXd>(res.x.data(), 3 * n) += dx;
  if (!rows.empty()) {
    Eigen::Index worst = 0;
    const double vmax = rows.violations().cwiseAbs().maxCoeff(&worst);
    if (vmax > options.plausible_violation)
      note("row " + std::to_string(worst) + " (" +
           to_string(rows[static_cast<index_t>(worst)].set) + ") is violated by " +
           std::to_string(vmax) + " mm, beyond the plausible " +
           std::to_string(options.plausible_violation) + " mm: mis-pairing or wrong frame?");
    if (res.pgs.stop == PgsStop::STALLED || res.pgs.ignored_rows > 0) note(res.pgs.message);
  }
  if (res.inverted_elements > 0) note(std::to_string(res.inverted_elements) + " inverted elements");
  res.diagnosis = diag;
  res.max_increment = Eigen::Map<const MatrixX3d>(dx.data(), n, 3).rowwise().norm().maxCoeff();
  logger().debug("step: |dx|max {:.4g} mm, PGS {} ({} sweeps), inverted {}", res.max_increment,
                 to_string(res.pgs.stop), res.pgs.iterations, res.inverted_elements);
  return res;
}

}  // namespace brainshift::constraints
