/// @file
/// @brief Independent-reference test: our static solver against CalculiX (ccx) on the same
/// tetrahedral cylinder, same fixed base and same prescribed top-face displacement.
///  - linear FEM (corotational = false) vs ccx C3D4 *STATIC without NLGEOM: must agree to the
///    precision ccx prints;
///  - corotational vs ccx NLGEOM (St. Venant–Kirchhoff with the *ELASTIC constants) at a 10 mm
///    sideways top displacement: the difference is measured, printed and bounded, and the
///    corotational answer must be closer to NLGEOM than linear FEM is.
/// Skipped when `ccx` is not on PATH (CI installs calculix-ccx, scripts/install_deps.sh).

#include "calculix.hpp"
#include "temp_folder.hpp"
#include "tolerance.hpp"

#include "core/solver/static_solver.hpp"
#include "core/units.hpp"
#include "data_synth/geometry/structured_mesh.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <limits>
#include <string>
#include <vector>

namespace brainshift::core {
namespace {

using tests::calculix::ccx_available;
using tests::calculix::max_nodal_difference;
using tests::calculix::run_ccx;
using tests::calculix::write_node_set;

constexpr double kRadius = 20.0 * units::mm;
constexpr double kLength = 80.0 * units::mm;
// 8 cells across the diameter, 32 along the axis: 9·9·33 = 2,673 nodes, 12,288 tetrahedra.
constexpr int kRadialCells = 8;
constexpr int kAxialCells = 32;

/// The cylinder problem: mesh, fixed base (z = 0) and top face (z = length) nodes.
struct Problem {
  TetMesh mesh;
  std::vector<index_t> base;
  std::vector<index_t> top;
};

Problem make_problem() {
  Problem p{data_synth::make_cylinder_mesh(kRadius, kLength, kRadialCells, kAxialCells), {}, {}};
  for (index_t i = 0; i < p.mesh.num_nodes(); ++i) {
    const double z = p.mesh.nodes()(i, 2);
    if (std::abs(z) < 1e-9) p.base.push_back(i);
    if (std::abs(z - kLength) < 1e-9) p.top.push_back(i);
  }
  return p;
}

/// Our solution: base fixed, top translated by `top_displacement`.
MatrixX3d solve_ours(const Problem& p, const Vector3d& top_displacement, bool corotational) {
  std::vector<index_t> dirichlet = p.base;
  dirichlet.insert(dirichlet.end(), p.top.begin(), p.top.end());
  const StaticSolver solver(p.mesh, dirichlet);
  std::vector<PrescribedDisplacement> prescribed;
  for (const index_t i : p.top) prescribed.push_back({i, top_displacement});
  StaticOptions options;
  options.corotational = corotational;
  options.increment_tolerance = 1e-12;  // converge far below the model differences measured here
  const StaticResult result = solver.solve(prescribed, options);
  EXPECT_EQ(result.status, SolveStatus::CONVERGED) << result.message;
  return result.displacement;
}

/// CalculiX input deck: C3D4 elements (our positive orientation is the Abaqus/ccx one: node 4 on
/// the side of face 1-2-3 given by the right-hand rule), one linear elastic material (mm, mN, kPa
/// = mN/mm²), base fixed, top translated; *STATIC with or without NLGEOM; displacements of all
/// nodes printed to the .dat file.
void write_inp(const std::filesystem::path& file, const Problem& p,
               const Vector3d& top_displacement, bool nlgeom) {
  const TetMesh& m = p.mesh;
  const double E = m.youngs_modulus()(0), nu = m.poisson_ratio()(0);
  ASSERT_TRUE((m.youngs_modulus().array() == E).all() && (m.poisson_ratio().array() == nu).all())
      << "the deck writes one material";
  std::ofstream out(file);
  out << "*HEADING\nbrainshift test_calculix cylinder\n";
  tests::calculix::write_mesh(out, m);
  write_node_set(out, "BASE", p.base);
  write_node_set(out, "TOP", p.top);
  out << "*MATERIAL, NAME=BRAIN\n*ELASTIC\n"
      << E << ", " << nu << "\n"
      << "*SOLID SECTION, ELSET=EALL, MATERIAL=BRAIN\n";
  if (nlgeom) {
    // Tighter than the defaults (0.005, 0.01) so that ccx's convergence error stays far below
    // the model difference measured here.
    out << "*STEP, NLGEOM, INC=1000\n*CONTROLS, PARAMETERS=FIELD\n1e-7, 1e-6\n"
        << "*STATIC\n0.1, 1.0\n";
  } else {
    out << "*STEP\n*STATIC\n";
  }
  out << "*BOUNDARY\nBASE, 1, 3, 0.\n";
  for (int a = 0; a < 3; ++a)
    out << "TOP, " << a + 1 << ", " << a + 1 << ", " << top_displacement(a) << "\n";
  out << "*NODE PRINT, NSET=NALL\nU\n*END STEP\n";
}

TEST(CalculixReference, LinearFemMatchesCalculixLinearC3D4) {
  if (!ccx_available()) GTEST_SKIP() << "ccx (CalculiX, Debian package calculix-ccx) not on PATH";
  const Problem p = make_problem();
  ASSERT_GE(p.mesh.num_nodes(), 2000);
  const Vector3d top(1.0, 0.0, 0.5);  // mm: 1 mm sideways, 0.5 mm axial stretch
  const tests::TempFolder folder;
  write_inp(folder / "linear.inp", p, top, /*nlgeom=*/false);
  double seconds = 0;
  const MatrixX3d u_ccx = run_ccx(folder.path(), "linear", p.mesh.num_nodes(), seconds);
  const MatrixX3d u_ours = solve_ours(p, top, /*corotational=*/false);
  const double rel = tests::relative_difference(u_ours, u_ccx);
  std::cout << "[calculix] linear: nodes " << p.mesh.num_nodes() << ", tets " << p.mesh.num_tets()
            << ", ccx " << seconds << " s, relative L2 difference " << rel << ", max nodal "
            << max_nodal_difference(u_ours, u_ccx) << " mm\n";
  // Same element (linear tet), same material, both direct solves in double precision: the
  // difference is set by ccx's .dat output, which prints 7 significant digits (1p e13.6), so each
  // printed component carries a relative rounding error ≤ 5e-7, hence ‖Δu‖/‖u‖ ≤ 5e-7. The .frd
  // is worse (e12.5, 6 digits) and ccx 2.20 has no option for more digits, so 1e-6 is the
  // tightest bound the reference can support (measured 5.7e-8; max nodal 5e-7 mm, i.e. the
  // last printed digit of a ~1 mm value).
  constexpr double kPrintedPrecision = 1e-6;
  EXPECT_LE(rel, kPrintedPrecision);
}

TEST(CalculixReference, CorotationalIsCloseToCalculixNlgeomAndCloserThanLinearFem) {
  if (!ccx_available()) GTEST_SKIP() << "ccx (CalculiX, Debian package calculix-ccx) not on PATH";
  const Problem p = make_problem();
  ASSERT_GE(p.mesh.num_nodes(), 2000);
  const Vector3d top(10.0, 0.0, 0.0);  // mm: 10 mm sideways shear of an 80 mm column
  const tests::TempFolder folder;
  write_inp(folder / "nlgeom.inp", p, top, /*nlgeom=*/true);
  double seconds = 0;
  const MatrixX3d u_ccx = run_ccx(folder.path(), "nlgeom", p.mesh.num_nodes(), seconds);
  const MatrixX3d u_corot = solve_ours(p, top, /*corotational=*/true);
  const MatrixX3d u_linear = solve_ours(p, top, /*corotational=*/false);
  const double rel_corot = tests::relative_difference(u_corot, u_ccx);
  const double rel_linear = tests::relative_difference(u_linear, u_ccx);
  const double max_corot = max_nodal_difference(u_corot, u_ccx);
  const double max_linear = max_nodal_difference(u_linear, u_ccx);
  std::cout << "[calculix] NLGEOM: ccx " << seconds << " s; corotational vs ccx: relative L2 "
            << rel_corot << ", max nodal " << max_corot << " mm; linear vs ccx: relative L2 "
            << rel_linear << ", max nodal " << max_linear << " mm\n";
  // Corotational linear elasticity and ccx's NLGEOM (St. Venant–Kirchhoff: Green–Lagrange strain,
  // PK2 stress with the same E, nu) coincide at small strain and under rigid rotation but differ
  // at finite strain: the Green–Lagrange terms are O(γ²/2) with the mean shear γ = 10/80, i.e.
  // ≈ 0.8 %. Measured (ccx 2.20, this mesh): relative L2 4.3e-3, max nodal 0.060 mm; linear FEM
  // vs NLGEOM 1.8e-2 and 0.23 mm. ccx's own error is negligible: Newton converged (last
  // correction 3e-5 of the increment) and the answer does not move when E is scaled by 1000.
  // Bounds: the γ²/2 estimate (1 %, about 2× the measurement, still below linear FEM's 1.8 %)
  // and 1.5 % of the imposed 10 mm for the worst node (2.5× the measurement).
  constexpr double kModelDifferenceRel = 1e-2;
  constexpr double kModelDifferenceMax = 0.15 * units::mm;
  EXPECT_LE(rel_corot, kModelDifferenceRel);
  EXPECT_LE(max_corot, kModelDifferenceMax);
  EXPECT_LT(rel_corot, rel_linear);
  EXPECT_LT(max_corot, max_linear);
}

}  // namespace
}  // namespace brainshift::core
