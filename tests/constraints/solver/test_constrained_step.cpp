#include "tolerance.hpp"

#include "constraints/fixtures.hpp"
#include "constraints/solver/constrained_step.hpp"

#include <Eigen/LU>
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <numbers>

namespace brainshift::constraints {
namespace {

using RowBuilder = std::function<ConstraintRows(const MatrixX3d&)>;

struct StepRun {
  MatrixX3d x;
  int steps = 0;
  bool converged = false;
  double last_increment = 0;
};

/// Repeats constrained steps, rebuilding the rows at each new x, until max |Δx| < tol (mm).
StepRun run_steps(ConstrainedModel& model, const RowBuilder& build, const StepOptions& o,
                  int max_steps, double tol) {
  StepRun r;
  r.x = model.model().mesh().nodes();
  Eigen::VectorXd lambda;
  for (r.steps = 1; r.steps <= max_steps; ++r.steps) {
    const ConstraintRows rows = build(r.x);
    StepResult s = model.step(r.x, rows, o, lambda);
    EXPECT_TRUE(s.x.allFinite());
    r.x = s.x;
    lambda = s.lambda;
    r.last_increment = s.max_increment;
    if (s.max_increment < tol) {
      r.converged = true;
      break;
    }
    if (s.max_increment > 1e6 || s.diagnosis.find("rejected") != std::string::npos)
      break;  // diverging: no point in going on
  }
  return r;
}

double deformed_volume(const core::TetMesh& mesh, const MatrixX3d& x) {
  double v = 0;
  for (index_t t = 0; t < mesh.num_tets(); ++t) {
    const auto& T = mesh.tets();
    v += core::signed_tet_volume(x.row(T(t, 0)), x.row(T(t, 1)), x.row(T(t, 2)), x.row(T(t, 3)));
  }
  return v;
}

TEST(ConstrainedStep, BilateralStepMatchesADirectKktSolve) {
  const auto mesh = data_synth::make_box_mesh({10, 10, 40}, {2, 2, 8});
  ConstrainedModel model(mesh, tests::nodes_below(mesh, 0), tests::all_nodes(mesh));
  const MatrixX3d& X = mesh.nodes();
  const auto top = tests::nodes_above(mesh, 40);
  ConstraintRows rows;
  rows.add_bilateral_point(tests::node_stencil(top[0]), X,
                           X.row(top[0]).transpose() + Vector3d(2, 0, -1), ConstraintSet::LANDMARK);
  rows.add_sliding_line(tests::node_stencil(top[8]), X,
                        X.row(top[8]).transpose() + Vector3d(0, 1, 0), Vector3d(1, 0, 0),
                        ConstraintSet::VESSELS);
  rows.add_sliding_plane(tests::node_stencil(40), X, X.row(40).transpose() + Vector3d(0.5, 0, 0),
                         Vector3d(1, 0, 0), ConstraintSet::DURA);
  StepOptions o;
  o.mechanics = Mechanics::LINEAR;
  o.pgs.tolerance = 1e-14;
  o.pgs.max_iterations = 20000;
  const StepResult s = model.step(X, rows, o);
  ASSERT_EQ(s.pgs.stop, PgsStop::CONVERGED) << s.pgs.message;

  // Direct: [K_ff −H_fᵀ; H_f 0] [dx_f; λ] = [0; −δ], dense LU.
  const auto& dofs = model.dofs();
  const Eigen::MatrixXd Kff = Eigen::MatrixXd(dofs.restrict(model.rest_stiffness()));
  const Eigen::MatrixXd H = Eigen::MatrixXd(rows.jacobian(mesh.num_nodes()));
  Eigen::MatrixXd Hf(H.rows(), dofs.num_free());
  for (index_t i = 0; i < dofs.num_free(); ++i) Hf.col(i) = H.col(dofs.full_index(i));
  const auto nf = dofs.num_free();
  const auto m = rows.size();
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(nf + m, nf + m);
  A.topLeftCorner(nf, nf) = Kff;
  A.topRightCorner(nf, m) = -Hf.transpose();
  A.bottomLeftCorner(m, nf) = Hf;
  Eigen::VectorXd b = Eigen::VectorXd::Zero(nf + m);
  b.tail(m) = -rows.violations();
  const Eigen::VectorXd sol = A.fullPivLu().solve(b);
  Eigen::VectorXd dx =
      Eigen::Map<const Eigen::VectorXd>((s.x - X).eval().data(), 3 * mesh.num_nodes());
  // The issue asks ≤ 1e-8 relative; PGS is run to 1e-14 and cond(KKT) ≈ 1e4.
  EXPECT_LT(tests::relative_difference(s.lambda, sol.tail(m)), 1e-8);
  EXPECT_LT(tests::relative_difference(dofs.restrict(dx), sol.head(nf)), 1e-8);
}

TEST(ConstrainedStep, UnilateralContactSatisfiesTheLcpConditions) {
  // A probe plane pressed 2 mm into the top of a beam, tilted so part of the top separates.
  const auto mesh = data_synth::make_box_mesh({20, 20, 40}, {4, 4, 8});
  ConstrainedModel model(mesh, tests::nodes_below(mesh, 0), tests::all_nodes(mesh));
  const MatrixX3d& X = mesh.nodes();
  const Vector3d normal = Vector3d(0.15, 0, -1).normalized();  // allowed side: below the plane
  const Vector3d point(10, 10, 38);
  ConstraintRows rows;
  for (index_t n : tests::nodes_above(mesh, 40))
    rows.add_unilateral_plane(tests::node_stencil(n), X, point, normal, ConstraintSet::FOOTPRINT);
  StepOptions o;
  o.mechanics = Mechanics::LINEAR;  // one linear step is exact: the LCP holds at the new x
  o.pgs.tolerance = 1e-12;
  o.pgs.max_iterations = 20000;
  const StepResult s = model.step(X, rows, o);
  ASSERT_EQ(s.pgs.stop, PgsStop::CONVERGED) << s.pgs.message;
  const Eigen::VectorXd g = rows.values(s.x);
  const double tol = 1e-9;  // mm; 1e-12 relative residual on ≈ 4 mm violations, with margin
  int contact = 0;
  for (index_t i = 0; i < rows.size(); ++i) {
    SCOPED_TRACE(i);
    EXPECT_GE(g[i], -tol);
    EXPECT_GE(s.lambda[i], 0.0);
    EXPECT_LE(std::abs(g[i] * s.lambda[i]), tol * s.lambda.maxCoeff());
    contact += s.lambda[i] > 0;
  }
  EXPECT_GT(contact, 0);
  EXPECT_LT(contact, rows.size());
}

TEST(ConstrainedStep, SlidingPointEndsOnItsLineButNotAtItsInitialProjection) {
  // Seed 002 fig. 5: node p slides on a line 2 mm away along y; its neighbour q is pulled 3 mm
  // along the line's direction. p must end on the line, dragged along it by q.
  const auto mesh = data_synth::make_box_mesh({20, 20, 40}, {4, 4, 8});
  ConstrainedModel model(mesh, tests::nodes_below(mesh, 0), tests::all_nodes(mesh));
  const MatrixX3d& X = mesh.nodes();
  const auto top = tests::nodes_above(mesh, 40);  // 25 nodes, x fastest
  const index_t p = top[12], q = top[13];         // centre and its +x neighbour
  const Vector3d line_point = X.row(p).transpose() + Vector3d(0, 2, 0);
  const Vector3d tangent = Vector3d::UnitX();
  const Vector3d q_target = X.row(q).transpose() + Vector3d(3, 0, 0);
  auto build = [&](const MatrixX3d& x) {
    ConstraintRows rows;
    rows.add_sliding_line(tests::node_stencil(p), x, line_point, tangent, ConstraintSet::VESSELS);
    rows.add_bilateral_point(tests::node_stencil(q), x, q_target, ConstraintSet::LANDMARK);
    return rows;
  };
  StepOptions o;
  o.pgs.tolerance = 1e-10;
  const StepRun r = run_steps(model, build, o, 50, 1e-7);
  ASSERT_TRUE(r.converged) << "last increment " << r.last_increment;
  const Vector3d pp = r.x.row(p).transpose();
  const Vector3d d = pp - line_point;
  const double off_line = (d - d.dot(tangent) * tangent).norm();
  EXPECT_LT(off_line, 1e-6);            // on its line, to the step tolerance
  const double slide = d.dot(tangent);  // initial projection is at 0 along the line
  EXPECT_GT(slide, 0.5) << "p did not slide along its line";
  EXPECT_LT((r.x.row(q).transpose() - q_target).norm(), 1e-6);
}

/// Targets bending a 10×10×100 beam (fixed at z = 0) into a circular arc of `degrees`: the top
/// face rotated about y and moved onto the arc.
struct BentBeam {
  core::TetMesh mesh = data_synth::make_box_mesh({10, 10, 100}, {2, 2, 20});
  std::vector<index_t> top = tests::nodes_above(mesh, 100);
  std::vector<Vector3d> target;
  explicit BentBeam(double degrees) {
    const double L = 100, th = degrees * std::numbers::pi / 180, rho = L / th;
    const Vector3d c_top(5, 5, 100), c_end(5 + rho - rho * std::cos(th), 5, rho * std::sin(th));
    const Matrix3d R = Eigen::AngleAxisd(th, Vector3d::UnitY()).toRotationMatrix();
    for (index_t n : top) target.push_back(c_end + R * (mesh.nodes().row(n).transpose() - c_top));
  }
  ConstraintRows rows(const MatrixX3d& x) const {
    ConstraintRows r;
    for (std::size_t k = 0; k < top.size(); ++k)
      r.add_bilateral_point(tests::node_stencil(top[k]), x, target[k], ConstraintSet::LANDMARK);
    return r;
  }
  double max_error(const MatrixX3d& x) const {
    double e = 0;
    for (std::size_t k = 0; k < top.size(); ++k)
      e = std::max(e, (x.row(top[k]).transpose() - target[k]).norm());
    return e;
  }
};

StepOptions beam_options(Mechanics m) {
  StepOptions o;
  o.mechanics = m;
  o.pgs.tolerance = 1e-10;        // 9 bilateral points on one face: W is ill-conditioned,
  o.pgs.max_iterations = 100000;  // so PGS needs many sweeps; run it to the tolerance
  o.pgs.stall_window = 100000;
  return o;
}

TEST(ConstrainedStep, ExactTangentStepsBendABeam90DegreesAndLinearFemGainsVolume) {
  const BentBeam scene(90);
  const double v0 = deformed_volume(scene.mesh, scene.mesh.nodes());
  auto build = [&](const MatrixX3d& x) { return scene.rows(x); };
  ConstrainedModel model(scene.mesh, tests::nodes_below(scene.mesh, 0), {});

  const StepRun exact = run_steps(model, build, beam_options(Mechanics::EXACT), 40, 1e-6);
  ASSERT_TRUE(exact.converged) << "exact tangent: last increment " << exact.last_increment;
  EXPECT_LT(scene.max_error(exact.x), 1e-5);  // constraints met to the step tolerance
  const double dv_exact = deformed_volume(scene.mesh, exact.x) / v0 - 1;

  // Linear FEM reaches the targets in one step (it is linear) but with the known artefact.
  const StepRun linear = run_steps(model, build, beam_options(Mechanics::LINEAR), 3, 1e-6);
  const double dv_linear = deformed_volume(scene.mesh, linear.x) / v0 - 1;
  std::cout << "[ beam 90 ] exact tangent: " << exact.steps << " steps, volume change " << dv_exact
            << "; linear FEM: volume change " << dv_linear << "\n";
  EXPECT_LT(std::abs(dv_exact), 0.03);  // corotational bending keeps volume (nu 0.45)
  EXPECT_GT(std::abs(dv_linear), 5 * std::abs(dv_exact));  // linear FEM under 90°: volume artefact
}

TEST(ConstrainedStep, WarpedStepsConvergeUnderModerateBendingWhereUnwarpedOnesDoNot) {
  // Warped compliance R K0⁻¹ Rᵀ is a good tangent while rotations vary little across the
  // compliance's reach (brain shift: < 15°). On this slender beam it converges at 20° of bend;
  // at 90° it does not (measured, see the note in docs/history/BENCHMARKS_NOTEBOOK.md), where EXACT
  // is needed.
  const BentBeam scene(20);
  auto build = [&](const MatrixX3d& x) { return scene.rows(x); };
  ConstrainedModel model(scene.mesh, tests::nodes_below(scene.mesh, 0), {});
  const StepRun warped = run_steps(model, build, beam_options(Mechanics::WARPED), 100, 1e-6);
  ASSERT_TRUE(warped.converged) << "warped: last increment " << warped.last_increment;
  EXPECT_LT(scene.max_error(warped.x), 1e-5);
  const StepRun exact = run_steps(model, build, beam_options(Mechanics::EXACT), 100, 1e-6);
  ASSERT_TRUE(exact.converged);
  // Same equilibrium: the fixed point does not depend on the compliance used to reach it.
  EXPECT_LT((warped.x - exact.x).cwiseAbs().maxCoeff(), 1e-4);
  const StepRun unwarped = run_steps(model, build, beam_options(Mechanics::UNWARPED), 100, 1e-6);
  std::cout << "[ beam 20 ] warped " << warped.steps << " steps, exact " << exact.steps
            << " steps, unwarped " << (unwarped.converged ? "" : "not converged after ")
            << unwarped.steps << " steps (last increment " << unwarped.last_increment << " mm)\n";
  EXPECT_TRUE(!unwarped.converged || unwarped.steps > warped.steps);
}

}  // namespace
}  // namespace brainshift::constraints
