#include "expect_error.hpp"
#include "tolerance.hpp"

#include "core/solver/static_solver.hpp"
#include "core/units.hpp"
#include "data_synth/geometry/structured_mesh.hpp"
#include "data_synth/truth/tled_solver.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <sstream>

namespace brainshift::data_synth {
namespace {

std::vector<index_t> nodes_where(const core::TetMesh& m, auto&& pred) {
  std::vector<index_t> out;
  for (index_t i = 0; i < m.num_nodes(); ++i)
    if (pred(Vector3d(m.nodes().row(i).transpose()))) out.push_back(i);
  return out;
}

/// Lateral stretch s of the decoupled neo-Hookean bar under axial stretch λ with free lateral
/// faces: the Cauchy stress σ = μ J^{−5/3} dev(b) + κ (J − 1) I has σ₂₂ = 0 (bisection).
double lateral_stretch(double lambda, const NeoHookean& m) {
  auto sigma22 = [&](double s) {
    const double J = lambda * s * s, I1 = lambda * lambda + 2 * s * s;
    return m.mu * std::pow(J, -5.0 / 3.0) * (s * s - I1 / 3.0) + m.kappa * (J - 1.0);
  };
  double lo = 0.2, hi = 2.0;  // σ₂₂ increases with s
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (lo + hi);
    (sigma22(mid) > 0 ? hi : lo) = mid;
  }
  return 0.5 * (lo + hi);
}

/// Nominal (first Piola) axial stress P₁₁ = J σ₁₁ / λ, kPa.
double nominal_stress(double lambda, double s, const NeoHookean& m) {
  const double J = lambda * s * s, I1 = lambda * lambda + 2 * s * s;
  const double sigma11 =
      m.mu * std::pow(J, -5.0 / 3.0) * (lambda * lambda - I1 / 3.0) + m.kappa * (J - 1.0);
  return J * sigma11 / lambda;
}

class UniaxialStretch : public ::testing::TestWithParam<double> {};

TEST_P(UniaxialStretch, MatchesTheClosedFormNeoHookeanForceAndLateralContraction) {
  const double lambda = GetParam();
  SCOPED_TRACE(::testing::Message() << "stretch " << lambda);
  // Stubby bar (L/W = 1.5): Euler buckling needs ≈ 37 % compression, far beyond 20 %.
  const double L = 6.0, W = 4.0;
  const core::TetMesh mesh = make_box_mesh({L, W, W}, {6, 4, 4}, {5.0, -3.0, 2.0});
  const Vector3d o(5.0, -3.0, 2.0);
  TledProblem p;
  for (const index_t i :
       nodes_where(mesh, [&](const Vector3d& x) { return std::abs(x.x() - o.x()) < 1e-9; })) {
    const Vector3d x = mesh.nodes().row(i).transpose() - o;
    // x = 0 face: u_x = 0; (0,0,0) also u_y = u_z = 0; (0,W,0) also u_z = 0 (no rigid rotation).
    const bool corner = x.norm() < 1e-9, edge = (x - Vector3d(0, W, 0)).norm() < 1e-9;
    p.constraints.push_back({i, {true, corner, corner || edge}, Vector3d::Zero()});
  }
  const auto end =
      nodes_where(mesh, [&](const Vector3d& x) { return std::abs(x.x() - o.x() - L) < 1e-9; });
  for (const index_t i : end)
    p.constraints.push_back({i, {true, false, false}, Vector3d((lambda - 1) * L, 0, 0)});
  const TledSolver solver(mesh);
  TledOptions opt;
  opt.error_tolerance = 1e-8;  // mm: far below the 1e-4 relative check
  opt.stiffness_safety = 2.0;  // headroom for the stiffening of large strains
  const TledResult r = solver.solve(p, opt);
  ASSERT_EQ(r.status, TledStatus::CONVERGED) << r.message;
  double force = 0.0;
  const MatrixX3d f = solver.internal_force(r.displacement);
  for (const index_t i : end) force += f(i, 0);
  const NeoHookean m =
      NeoHookean::from_youngs(units::brain_youngs_modulus, units::default_poisson_ratio);
  const double s = lateral_stretch(lambda, m);
  const double analytic = nominal_stress(lambda, s, m) * W * W;  // mN
  // Linear tets reproduce the homogeneous solution exactly, so only the relaxation error
  // (1e-8 mm on ~mm displacements) remains: 1e-5 relative is a generous bound.
  EXPECT_TRUE(tests::near(force, analytic, 0.0, 1e-5)) << r.message;
  const auto far = nodes_where(
      mesh, [&](const Vector3d& x) { return (x - o - Vector3d(L, W, W)).norm() < 1e-9; });
  EXPECT_TRUE(tests::near(W + r.displacement(far[0], 1), s * W, 0.0, 1e-5));
  EXPECT_TRUE(tests::near(W + r.displacement(far[0], 2), s * W, 0.0, 1e-5));
  std::ostringstream rel;
  rel << std::scientific << std::abs(force / analytic - 1);
  RecordProperty("force_relative_error", rel.str());
}

INSTANTIATE_TEST_SUITE_P(TledSolver, UniaxialStretch, ::testing::Values(0.8, 1.3));

TEST(TledSolver, InternalForceIsTheGradientOfTheStrainEnergy) {
  const core::TetMesh mesh = make_box_mesh({3, 2, 2}, {3, 2, 2});
  const TledSolver solver(mesh);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> d(-0.2, 0.2);
  MatrixX3d u(mesh.num_nodes(), 3);
  for (index_t i = 0; i < u.rows(); ++i) u.row(i) << d(rng), d(rng), d(rng);
  const MatrixX3d f = solver.internal_force(u);
  // Central differences, step 1e-6 mm: truncation ≈ 1e-12, rounding ≈ eps Ψ / h ≈ 1e-10 mN.
  constexpr double h = 1e-6;
  MatrixX3d fd(u.rows(), 3);
  for (index_t i = 0; i < u.rows(); ++i)
    for (int c = 0; c < 3; ++c) {
      MatrixX3d up = u, um = u;
      up(i, c) += h;
      um(i, c) -= h;
      fd(i, c) = (solver.strain_energy(up) - solver.strain_energy(um)) / (2 * h);
    }
  EXPECT_LT(tests::relative_difference(f, fd), 1e-7);
}

/// A column fixed at its base under (scaled) gravity, with a stiff upper half.
struct Column {
  core::TetMesh mesh;
  std::vector<index_t> base;
  Column() {
    const core::TetMesh box = make_box_mesh({20, 20, 30}, {5, 5, 8}, {-10, 40, -5});
    Eigen::VectorXd E(box.num_tets());
    for (index_t t = 0; t < box.num_tets(); ++t)
      E(t) = box.tet_nodes(t).col(2).mean() > 10 ? units::tumour_youngs_modulus
                                                 : units::brain_youngs_modulus;
    mesh = core::TetMesh(box.nodes(), box.tets(), E);
    base = nodes_where(mesh, [](const Vector3d& x) { return std::abs(x.z() + 5) < 1e-9; });
  }
  [[nodiscard]] TledProblem problem(const Vector3d& g) const {
    TledProblem p;
    const core::CorotationalModel model(mesh);
    const Eigen::VectorXd f = model.gravity_force(g, units::brain_density);
    p.external_force = Eigen::Map<const MatrixX3d>(f.data(), mesh.num_nodes(), 3);
    for (const index_t i : base) p.constraints.push_back({i, {true, true, true}, Vector3d::Zero()});
    return p;
  }
};

TEST(TledSolver, SmallLoadMatchesLinearFem) {
  const Column column;
  // Gravity scaled by 2e-4 (oblique): strains ≈ ρ g H / E · 2e-4 ≈ 4e-5, so the non-linear
  // terms are ≈ 1e-4 of the answer, below the 1e-3 agreement asked for.
  const Vector3d g = 2e-4 * units::standard_gravity * Vector3d(0.3, -0.2, -1.0).normalized();
  core::StaticOptions lin;
  lin.corotational = false;
  lin.gravity = g;
  lin.density = units::brain_density;
  const core::StaticResult ref = core::StaticSolver(column.mesh, column.base).solve({}, lin);
  ASSERT_EQ(ref.status, core::SolveStatus::CONVERGED) << ref.message;
  const double umax = ref.displacement.rowwise().norm().maxCoeff();
  TledOptions opt;
  opt.error_tolerance = 1e-5 * umax;
  const TledResult r = TledSolver(column.mesh).solve(column.problem(g), opt);
  ASSERT_EQ(r.status, TledStatus::CONVERGED) << r.message;
  const double rel = tests::relative_difference(r.displacement, ref.displacement);
  EXPECT_LT(rel, 1e-3) << "max |u| " << umax << " mm, " << r.iterations << " steps";
  RecordProperty("linear_relative_difference", std::to_string(rel));
}

TEST(TledSolver, EstimatedErrorBoundsTheTrueError) {
  const Column column;
  const Vector3d g(0.0, 0.0, -0.1 * units::standard_gravity);
  TledOptions tight;
  tight.error_tolerance = 1e-9;
  const TledSolver solver(column.mesh);
  const TledResult ref = solver.solve(column.problem(g), tight);
  ASSERT_EQ(ref.status, TledStatus::CONVERGED) << ref.message;
  TledOptions loose;
  loose.error_tolerance = 1e-3 * ref.max_displacement;
  const TledResult r = solver.solve(column.problem(g), loose);
  ASSERT_EQ(r.status, TledStatus::CONVERGED) << r.message;
  const double err = (r.displacement - ref.displacement).rowwise().norm().maxCoeff();
  // The stopping rule promises |u − u*|∞ ≲ tolerance; allow ×2 for the asymptotic estimate.
  EXPECT_LT(err, 2.0 * loose.error_tolerance) << "estimated " << r.estimated_error;
  EXPECT_LT(r.iterations, ref.iterations);
}

TEST(TledSolver, ReportsTheIterationCapWithAFiniteIterate) {
  const Column column;
  TledOptions opt;
  opt.max_iterations = 300;
  const TledResult r = TledSolver(column.mesh).solve(column.problem({0, 0, -9810}), opt);
  EXPECT_EQ(r.status, TledStatus::MAX_ITERATIONS);
  EXPECT_EQ(r.iterations, 300);
  EXPECT_TRUE(r.displacement.allFinite());
  EXPECT_GT(r.estimated_error, opt.error_tolerance);
}

TEST(TledSolver, ReportsDivergenceInsteadOfNaN) {
  const Column column;
  // 1e4 g crushes the soft column: elements invert, which must be a status, not NaN.
  const TledResult r = TledSolver(column.mesh).solve(column.problem({0, 0, -1e4 * 9810}), {});
  EXPECT_EQ(r.status, TledStatus::DIVERGED) << r.message;
  EXPECT_TRUE(r.displacement.allFinite());
  EXPECT_NE(r.message.find("step"), std::string::npos) << r.message;
}

TEST(TledSolver, RejectsBadInput) {
  const Column column;
  const TledSolver solver(column.mesh);
  TledOptions bad;
  bad.error_tolerance = 0.0;
  tests::expect_error(
      [&] {
        (void)solver.solve(column.problem({0, 0, -1}), bad);
      },
      {"error_tolerance"});
  TledProblem p = column.problem({0, 0, -1});
  p.constraints.push_back({column.mesh.num_nodes(), {true, true, true}, Vector3d::Zero()});
  tests::expect_error([&] { (void)solver.solve(p, {}); }, {"constraint on node"});
  p = column.problem({0, 0, -1});
  p.external_force.resize(3, 3);
  tests::expect_error([&] { (void)solver.solve(p, {}); }, {"external force", "rows"});
}

}  // namespace
}  // namespace brainshift::data_synth
