#include "tolerance.hpp"

#include "core/error.hpp"
#include "core/solver/static_solver.hpp"
#include "core/units.hpp"
#include "data_synth/geometry/structured_mesh.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <iostream>
#include <limits>
#include <optional>
#include <string>

namespace brainshift::core {
namespace {

bool on_box_boundary(const Vector3d& p, const Vector3d& lo, const Vector3d& hi) {
  for (int a = 0; a < 3; ++a)
    if (std::abs(p(a) - lo(a)) < 1e-9 || std::abs(p(a) - hi(a)) < 1e-9) return true;
  return false;
}

std::vector<index_t> nodes_where(const TetMesh& mesh,
                                 const std::function<bool(const Vector3d&)>& f) {
  std::vector<index_t> out;
  for (index_t i = 0; i < mesh.num_nodes(); ++i)
    if (f(mesh.nodes().row(i).transpose())) out.push_back(i);
  return out;
}

/// Prescribes x = map(X) on the given nodes.
std::vector<PrescribedDisplacement> prescribe(const TetMesh& mesh,
                                              const std::vector<index_t>& nodes,
                                              const std::function<Vector3d(const Vector3d&)>& map) {
  std::vector<PrescribedDisplacement> out;
  for (const index_t i : nodes) {
    const Vector3d X = mesh.nodes().row(i).transpose();
    out.push_back({i, map(X) - X});
  }
  return out;
}

MatrixX3d field(const TetMesh& mesh, const std::function<Vector3d(const Vector3d&)>& map) {
  MatrixX3d u(mesh.num_nodes(), 3);
  for (index_t i = 0; i < mesh.num_nodes(); ++i) {
    const Vector3d X = mesh.nodes().row(i).transpose();
    u.row(i) = (map(X) - X).transpose();
  }
  return u;
}

Matrix3d axis_angle(double degrees, const Vector3d& axis) {
  return Eigen::AngleAxisd(degrees * M_PI / 180.0, axis.normalized()).toRotationMatrix();
}

StaticOptions tight(bool corotational) {
  StaticOptions o;
  o.corotational = corotational;
  o.increment_tolerance = 1e-13;
  o.max_iterations = 500;
  return o;
}

// ---------------------------------------------------------------------------------------------
// 1. Patch test

class PatchTest : public ::testing::TestWithParam<bool> {};

TEST_P(PatchTest, AffineBoundaryDisplacementIsReproducedInTheInterior) {
  const bool corotational = GetParam();
  SCOPED_TRACE(corotational ? "corotational" : "linear");
  const Vector3d lo(-5, -4, -6);
  const Vector3d hi(5, 4, 6);
  const TetMesh mesh = data_synth::make_box_mesh(hi - lo, {4, 3, 5}, lo);
  const auto boundary =
      nodes_where(mesh, [&](const Vector3d& p) { return on_box_boundary(p, lo, hi); });
  // Affine map: 30° rotation of a 5 % stretched/sheared body, plus a translation.
  Matrix3d A;
  A << 1.05, 0.02, -0.01, 0.01, 0.97, 0.03, -0.02, 0.0, 1.02;
  const Matrix3d F = axis_angle(30, Vector3d(1, 2, 3)) * A;
  const auto map = [&](const Vector3d& X) -> Vector3d { return F * X + Vector3d(1, -2, 0.5); };
  const StaticSolver solver(mesh, boundary);
  const StaticResult r = solver.solve(prescribe(mesh, boundary, map), tight(corotational));
  ASSERT_EQ(r.status, SolveStatus::CONVERGED) << r.message;
  if (!corotational) {
    EXPECT_EQ(r.iterations, 1);  // linear FEM is one solve
  }
  const MatrixX3d expected = field(mesh, map);
  const double err = tests::relative_difference(r.displacement, expected);
  // Linear tets represent affine fields exactly; what remains is solve rounding (cond ~1e3) and,
  // for the corotational iteration, the 1e-13 increment tolerance: 1e-9 relative.
  EXPECT_LE(err, 1e-9);
  std::cout << "[ measured ] patch test " << (corotational ? "corotational" : "linear")
            << ": relative error " << err << " after " << r.iterations << " iterations\n";
  EXPECT_EQ(r.inverted_elements, 0);
}

INSTANTIATE_TEST_SUITE_P(StaticSolver, PatchTest, ::testing::Bool(), [](const auto& param_info) {
  return param_info.param ? "corotational" : "linear";
});

// ---------------------------------------------------------------------------------------------
// 5. Strong rotation (PRIOR_ART: CalculiX NLGEOM, cube rotated 60°, 2 % compression)

TEST(StaticSolver, CubeRotatedSixtyDegreesUnderCompressionEqualsTheRotatedLinearAnswer) {
  const double L = 20.0;
  const Vector3d lo = Vector3d::Constant(-L / 2);
  const TetMesh mesh = data_synth::make_box_mesh(Vector3d::Constant(L), {5, 5, 5}, lo);
  const auto bottom =
      nodes_where(mesh, [&](const Vector3d& p) { return std::abs(p.z() + L / 2) < 1e-9; });
  const auto top =
      nodes_where(mesh, [&](const Vector3d& p) { return std::abs(p.z() - L / 2) < 1e-9; });
  std::vector<index_t> faces = bottom;
  faces.insert(faces.end(), top.begin(), top.end());
  const StaticSolver solver(mesh, faces);
  const Vector3d squeeze(0, 0, -0.02 * L);  // 2 % compression, faces clamped

  // Reference: the unrotated problem, small-strain linear answer u_lin.
  auto reference = prescribe(mesh, top, [&](const Vector3d& X) -> Vector3d { return X + squeeze; });
  const StaticResult lin_ref = solver.solve(reference, tight(false));
  const StaticResult cr_ref = solver.solve(reference, tight(true));
  ASSERT_EQ(lin_ref.status, SolveStatus::CONVERGED);
  ASSERT_EQ(cr_ref.status, SolveStatus::CONVERGED);

  // The same problem rotated 60° about an oblique axis through the cube's centre.
  const Matrix3d Q = axis_angle(60, Vector3d(1, 2, 0.5));
  auto rotated = prescribe(mesh, bottom, [&](const Vector3d& X) -> Vector3d { return Q * X; });
  const auto rotated_top =
      prescribe(mesh, top, [&](const Vector3d& X) -> Vector3d { return Q * (X + squeeze); });
  rotated.insert(rotated.end(), rotated_top.begin(), rotated_top.end());
  const StaticResult cr = solver.solve(rotated, tight(true));
  const StaticResult lin = solver.solve(rotated, tight(false));
  ASSERT_EQ(cr.status, SolveStatus::CONVERGED) << cr.message;
  EXPECT_EQ(cr.inverted_elements, 0);

  // Expected: x = Q (X + u_lin), i.e. u = (Q − I) X + Q u_lin.
  const MatrixX3d X = mesh.nodes();
  const MatrixX3d rigid = X * Q.transpose() - X;
  const MatrixX3d expected = rigid + lin_ref.displacement * Q.transpose();
  const double cr_total = tests::relative_difference(cr.displacement, expected);
  const double lin_total = tests::relative_difference(lin.displacement, expected);
  const double deformation = lin_ref.displacement.norm();
  const double cr_def = (cr.displacement - expected).norm() / deformation;
  const double lin_def = (lin.displacement - expected).norm() / deformation;
  // Exact rotation equivariance of the corotational model: rotated solution = Q × reference.
  const MatrixX3d cr_expected = rigid + cr_ref.displacement * Q.transpose();
  const double equivariance = (cr.displacement - cr_expected).norm() / deformation;
  std::cout << "[ measured ] 60° cube, relative to the total displacement: corotational "
            << cr_total << ", linear " << lin_total << "\n"
            << "[ measured ] 60° cube, relative to the deformation ‖u_lin‖: corotational " << cr_def
            << ", linear " << lin_def << "; corotational rotation equivariance " << equivariance
            << " (" << cr.iterations << " iterations)\n";
  // Corotational vs the rotated linear answer, relative to the total displacement (as CalculiX
  // NLGEOM, 5e-5): they differ only by the geometric non-linearity of the unrotated problem
  // (element rotations ~1e-2 times the 2 % strain, measured 2e-3 of ‖u_lin‖), i.e. O(1e-4) of
  // the total displacement. Measured 5.2e-5.
  EXPECT_LE(cr_total, 1e-4);
  // Exact rotation equivariance: to the 1e-13 increment tolerance and solve rounding.
  EXPECT_LE(equivariance, 1e-8);
  // Plain linear FEM sees the 60° rotation as a strain of (cos 60° − 1) = −50 % and the free
  // lateral faces respond to it: badly off (measured 45 % of the total displacement).
  EXPECT_GT(lin_total, 0.05);
}

TEST(StaticSolver, CorotationalEqualsLinearAtSmallStrain) {
  const TetMesh mesh = data_synth::make_box_mesh({10, 10, 20}, {3, 3, 6});
  const auto bottom = nodes_where(mesh, [](const Vector3d& p) { return p.z() < 1e-9; });
  const auto top = nodes_where(mesh, [](const Vector3d& p) { return p.z() > 20 - 1e-9; });
  std::vector<index_t> faces = bottom;
  faces.insert(faces.end(), top.begin(), top.end());
  const StaticSolver solver(mesh, faces);
  // 1e-6 compression plus 1e-6 shear of the top face: strain 1e-6, bending rotations ~1e-6.
  const auto load = prescribe(
      mesh, top, [](const Vector3d& X) -> Vector3d { return X + Vector3d(2e-5, 0, -2e-5); });
  const StaticResult lin = solver.solve(load, tight(false));
  const StaticResult cr = solver.solve(load, tight(true));
  ASSERT_EQ(cr.status, SolveStatus::CONVERGED) << cr.message;
  const double diff = tests::relative_difference(cr.displacement, lin.displacement);
  std::cout << "[ measured ] static corotational vs linear at 1e-6 strain: " << diff << "\n";
  // Geometric non-linearity is O(strain) relative; rounding of x − X is ε‖X‖/‖u‖ ≈ 1e-10.
  EXPECT_LE(diff, 1e-6);
}

// ---------------------------------------------------------------------------------------------
// 9. Gravity

TEST(StaticSolver, CylinderUnderGravityFixedAtOneEndConverges) {
  // Radius 20 mm, length 40 mm, tumour-stiff (10 kPa): Euler–Bernoulli sag ≈ 3 mm, so the
  // tip rotates ~0.1 rad and the corotational iterations matter.
  const TetMesh cyl = data_synth::make_cylinder_mesh(20, 40, 6, 8);
  const TetMesh mesh(cyl.nodes(), cyl.tets(), Eigen::VectorXd::Constant(cyl.num_tets(), 10.0),
                     Eigen::VectorXd::Constant(cyl.num_tets(), 0.45));
  const auto base = nodes_where(mesh, [](const Vector3d& p) { return std::abs(p.z()) < 1e-9; });
  const StaticSolver solver(mesh, base);
  StaticOptions o;
  o.gravity = Vector3d(-9810, 0, 0);  // sideways: the cylinder bends like a cantilever
  const StaticResult cr = solver.solve({}, o);
  ASSERT_EQ(cr.status, SolveStatus::CONVERGED) << cr.message;
  o.corotational = false;
  const StaticResult lin = solver.solve({}, o);
  ASSERT_EQ(lin.status, SolveStatus::CONVERGED) << lin.message;
  EXPECT_TRUE(cr.displacement.allFinite());
  EXPECT_EQ(cr.inverted_elements, 0);
  // Default tolerance 1e-6 on the increment: the residual is small, not zero.
  EXPECT_LE(cr.final_residual, 1e-4) << cr.final_residual;
  const double tip_cr = cr.displacement.col(0).minCoeff();
  const double tip_lin = lin.displacement.col(0).minCoeff();
  EXPECT_LT(tip_cr, 0.0);  // sags along gravity
  // Moderate rotation (~0.1 rad): the geometric non-linearity changes the sag by a few %.
  EXPECT_TRUE(tests::near(tip_cr, tip_lin, 0, 0.10)) << tip_cr << " vs " << tip_lin;
  std::cout << "[ measured ] cylinder tip sag: corotational " << tip_cr << " mm, linear " << tip_lin
            << " mm, " << cr.iterations << " iterations\n";
}

/// Mean vertical tip displacement (mm) of a clamped L×h×h beam (L = 100 mm, h = 10 mm) under
/// its own weight, linear FEM with `across` cubic-ish cells through the thickness.
double cantilever_tip_deflection(int across, double youngs_modulus, double density) {
  const double L = 100.0;
  const double h = 10.0;
  const TetMesh base = data_synth::make_box_mesh({L, h, h}, {5 * across, across, across});
  const TetMesh mesh(base.nodes(), base.tets(),
                     Eigen::VectorXd::Constant(base.num_tets(), youngs_modulus),
                     Eigen::VectorXd::Constant(base.num_tets(), 0.3));
  const auto clamp = nodes_where(mesh, [](const Vector3d& p) { return std::abs(p.x()) < 1e-9; });
  const StaticSolver solver(mesh, clamp);
  StaticOptions o;
  o.corotational = false;
  o.gravity = Vector3d(0, 0, -9810);
  o.density = density;
  const StaticResult r = solver.solve({}, o);
  EXPECT_EQ(r.status, SolveStatus::CONVERGED) << r.message;
  const auto tip = nodes_where(mesh, [&](const Vector3d& p) { return std::abs(p.x() - L) < 1e-9; });
  double w = 0.0;
  for (const index_t i : tip) w += r.displacement(i, 2);
  return w / static_cast<double>(tip.size());
}

TEST(StaticSolver, SlenderCantileverMatchesEulerBernoulli) {
  const double L = 100.0;
  const double h = 10.0;
  const double E = 1e4;  // kPa, a stiff beam (sag ≈ 1.5 mm, small strain); linear: E only scales
  const double rho = units::brain_density;
  const double q = rho * 9810.0 * h * h;  // weight per length, mN/mm
  const double I = h * h * h * h / 12.0;
  const double beam = -q * std::pow(L, 4) / (8.0 * E * I);
  const double coarse = cantilever_tip_deflection(4, E, rho);
  const double fine = cantilever_tip_deflection(8, E, rho);
  // Linear tetrahedra lock in bending; the error falls roughly as h² (measured 32 % → 11 %),
  // so the Richardson extrapolation (4·fine − coarse)/3 removes most of it.
  const double extrapolated = (4.0 * fine - coarse) / 3.0;
  const double err_coarse = std::abs(coarse - beam) / std::abs(beam);
  const double err_fine = std::abs(fine - beam) / std::abs(beam);
  const double err_extrapolated = std::abs(extrapolated - beam) / std::abs(beam);
  std::cout << "[ measured ] cantilever tip vs Euler-Bernoulli " << beam << " mm: 4 across "
            << coarse << " (" << err_coarse << "), 8 across " << fine << " (" << err_fine
            << "), extrapolated " << extrapolated << " (" << err_extrapolated << ")\n";
  // 8 elements through the thickness: shear locking of linear tets leaves ~11 % (too stiff).
  EXPECT_LE(err_fine, 0.12);
  EXPECT_LT(std::abs(fine), std::abs(beam));  // locking makes it stiffer, never softer
  EXPECT_LT(err_fine, 0.5 * err_coarse);      // and the error shrinks faster than h
  // What remains after extrapolation: the rate is not exactly 2, Timoshenko shear (≈1 % at
  // L/h = 10) and the clamp's Poisson restraint: 5 %.
  EXPECT_LE(err_extrapolated, 0.05);
}

// ---------------------------------------------------------------------------------------------
// 6, 7. Bad inputs and failures

TEST(StaticSolver, UnderConstrainedModelReportsFactorFailedWithoutThrowing) {
  const TetMesh mesh = data_synth::make_box_mesh({10, 10, 10}, {2, 2, 2});
  StaticOptions o;
  o.gravity = Vector3d(0, 0, -9810);
  for (const std::vector<index_t>& fixed :
       {std::vector<index_t>{}, std::vector<index_t>{0}, std::vector<index_t>{0, 1, 2}}) {
    SCOPED_TRACE(std::to_string(fixed.size()) + " fixed nodes");  // {0,1,2} lie on one line
    std::optional<StaticSolver> solver;
    ASSERT_NO_THROW(solver.emplace(mesh, fixed));
    StaticResult r;
    ASSERT_NO_THROW(r = solver->solve({}, o));
    EXPECT_EQ(r.status, SolveStatus::FACTOR_FAILED);
    EXPECT_NE(r.message.find("under-constrained"), std::string::npos) << r.message;
    EXPECT_TRUE(r.displacement.allFinite());
    EXPECT_EQ(r.displacement.rows(), mesh.num_nodes());
  }
}

TEST(StaticSolver, BadInputsThrowNamingTheNodeOrElement) {
  const TetMesh mesh = data_synth::make_box_mesh({10, 10, 10}, {2, 2, 2});
  const auto bottom = nodes_where(mesh, [](const Vector3d& p) { return p.z() < 1e-9; });
  const StaticSolver solver(mesh, bottom);
  auto expect_message = [](const std::function<void()>& f, const std::string& what) {
    try {
      f();
      FAIL() << "no error, expected one naming " << what;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
    }
  };
  expect_message([&] { (void)solver.solve({{13, Vector3d(1, 0, 0)}}, {}); }, "node 13");
  expect_message(
      [&] {
        (void)solver.solve({{bottom[2], Vector3d(std::numeric_limits<double>::quiet_NaN(), 0, 0)}},
                           {});
      },
      "node " + std::to_string(bottom[2]));
  StaticOptions bad;
  bad.increment_tolerance = -1;
  expect_message([&] { (void)solver.solve({}, bad); }, "increment_tolerance");

  MatrixX3d X = mesh.nodes();
  X(5, 1) = std::numeric_limits<double>::infinity();
  expect_message([&] { const StaticSolver s(TetMesh(X, mesh.tets()), bottom); }, "node 5");
  MatrixX4i T = mesh.tets();
  std::swap(T(7, 1), T(7, 2));  // inverts tetrahedron 7
  expect_message([&] { const StaticSolver s(TetMesh(mesh.nodes(), T), bottom); }, "tetrahedron 7");
  expect_message([&] { const StaticSolver s(mesh, {999}); }, "999");
}

TEST(StaticSolver, ElementsInvertedDuringTheSolveAreCountedNeverNaN) {
  const TetMesh mesh = data_synth::make_box_mesh({10, 10, 10}, {2, 2, 2});
  const auto bottom = nodes_where(mesh, [](const Vector3d& p) { return p.z() < 1e-9; });
  const auto top = nodes_where(mesh, [](const Vector3d& p) { return p.z() > 10 - 1e-9; });
  std::vector<index_t> fixed = bottom;
  fixed.insert(fixed.end(), top.begin(), top.end());
  const StaticSolver solver(mesh, fixed);
  // The top face is pushed 15 mm down, through the fixed bottom face: the body must invert.
  const auto through =
      prescribe(mesh, top, [](const Vector3d& X) -> Vector3d { return X + Vector3d(0, 0, -15); });
  for (const bool corotational : {true, false}) {
    SCOPED_TRACE(corotational ? "corotational" : "linear");
    StaticOptions o;
    o.corotational = corotational;
    o.max_iterations = 50;
    StaticResult r;
    ASSERT_NO_THROW(r = solver.solve(through, o));
    EXPECT_TRUE(r.displacement.allFinite());
    EXPECT_TRUE(std::isfinite(r.final_residual));
    EXPECT_GT(r.inverted_elements, 0) << to_string(r.status) << ": " << r.message;
    std::cout << "[ measured ] pushed through (" << (corotational ? "corotational" : "linear")
              << "): " << to_string(r.status) << ", " << r.inverted_elements << " of "
              << mesh.num_tets() << " inverted, " << r.iterations << " iterations\n";
  }
}

TEST(StaticSolver, EveryNodePrescribedReturnsThePrescription) {
  const TetMesh mesh = data_synth::make_box_mesh({1, 1, 1}, {1, 1, 1});
  std::vector<index_t> all(static_cast<std::size_t>(mesh.num_nodes()));
  for (index_t i = 0; i < mesh.num_nodes(); ++i) all[static_cast<std::size_t>(i)] = i;
  const StaticSolver solver(mesh, all);
  const StaticResult r = solver.solve({{3, Vector3d(0.1, 0.2, 0.3)}}, {});
  EXPECT_EQ(r.status, SolveStatus::CONVERGED);
  // (X + u) − X rounds at ε·|X| = ε for the unit cube.
  EXPECT_LE((r.displacement.row(3) - Eigen::RowVector3d(0.1, 0.2, 0.3)).norm(), 4 * tests::eps);
  EXPECT_EQ(r.displacement.row(0).norm(), 0.0);
}

}  // namespace
}  // namespace brainshift::core
