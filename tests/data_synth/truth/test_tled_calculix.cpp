/// @file
/// @brief Independent check of the phantoms' truth model: the TLED neo-Hookean explicit solver
/// (tled_solver.hpp) against CalculiX (ccx) implicit static NLGEOM on the same tetrahedral mesh,
/// with the same material, loads and supports:
///  - a cube sheared and compressed by a prescribed top-face displacement (finite strain);
///  - a clamped-clamped block sagging under its own weight (gravity, geometric and material
///    non-linearity), without contact;
///  - the same block with a frictionless rigid plane below it that stops the sag (contact);
///  - the default phantom, coarse (8 mm cells), under the phantom cases' sag load with the skull
///    contact (curved skull: looser tolerance, see that test).
///
/// Same discrete model on both sides, so the answers must agree far below the 1 mm registration
/// target:
///  - element: ccx C3D4 is the constant-strain linear tetrahedron with one integration point, as
///    TLED's elements (deformation gradient from the shape gradients, total Lagrangian);
///  - material: ccx *HYPERELASTIC, NEO HOOKE has U = C10 (Ī₁ − 3) + (J − 1)² / D1 (ccx manual,
///    polynomial hyperelastic form, N = 1), ours W = μ/2 (Ī₁ − 3) + κ/2 (J − 1)²
///    (neo_hookean.hpp), the same decoupled form, hence C10 = μ/2 and D1 = 2/κ;
///  - loads: our nodal weights are sag_nodal_force's lumped quarter volumes; ccx integrates
///    *DLOAD GRAV itself with *DENSITY (for a linear tetrahedron the consistent load is also
///    ρ g V/4 per node), so brain_sag.cpp's load is checked too; both are dead loads;
///  - contact: TLED projects escaped candidate nodes onto a rigid ellipsoid (frictionless,
///    nodal); the plane is an ellipsoid flat enough to be a plane here (semi-axes 10⁶, 10⁶, 100
///    mm: it rises by (x² + y²)·100/(2·10¹²) ≤ 1e-7 mm over the block). ccx uses one GAPUNI
///    element per candidate node against a fixed ground node (nodal, frictionless, the gap
///    direction is the plane's normal): the same node-to-plane formulation, enforced by a
///    penalty (stiffness kGapStiffness: penetration = force / k ≤ 1e-6 mm here).
/// What remains are the two solvers' stopping errors (TLED dynamic relaxation to its estimated
/// error; ccx Newton with *CONTROLS tightened) and the 7 significant digits ccx prints: the
/// tolerances below are set from those, with the measured differences in the comments.
/// Skipped when `ccx` is not on PATH (CI installs calculix-ccx, scripts/install_deps.sh).

#include "calculix.hpp"
#include "temp_folder.hpp"
#include "tolerance.hpp"

#include "core/units.hpp"
#include "data_synth/geometry/structured_mesh.hpp"
#include "data_synth/truth/brain_sag.hpp"
#include "data_synth/truth/tled_solver.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <optional>
#include <string>
#include <vector>

namespace brainshift::data_synth {
namespace {

using tests::calculix::ccx_available;
using tests::calculix::max_nodal_difference;
using tests::calculix::run_ccx;
using tests::calculix::write_node_set;

/// GAPUNI penalty stiffness, mN/mm: nodal contact forces here are below 1 mN (a node carries
/// ρ g V/4 ≈ 0.02 mN and the plane holds up the block's middle), so the penetration is ≤ 1e-6 mm.
constexpr double kGapStiffness = 1e6;
/// GAPUNI force at infinite clearance, mN (ccx's default 1e-3 mN would pull open-gap nodes by
/// 5 % of a nodal weight): 1e-9 mN is 1e-7 of a nodal weight.
constexpr double kGapOpenForce = 1e-9;
/// TLED stopping tolerance, mm: a tenth of the agreement asserted below.
constexpr double kTledTolerance = 1e-4;

/// A prescribed-displacement group: all three components of `nodes` set to `displacement` (mm).
struct Support {
  std::string name;  ///< ccx node-set name
  std::vector<index_t> nodes;
  Vector3d displacement = Vector3d::Zero();
};

/// One ccx GAPUNI element: `node` may approach the fixed point `ground` along the unit
/// `direction` (from the node towards the obstacle) by at most `clearance` (mm).
struct Gap {
  index_t node = -1;
  Vector3d direction = -Vector3d::UnitZ();
  double clearance = 0.0;
  Vector3d ground = Vector3d::Zero();
};

/// One benchmark: mesh (E, ν per tetrahedron), supports, loads and the rigid obstacle, given
/// to TLED as its skull ellipsoid and to ccx as gap elements.
struct Bench {
  core::TetMesh mesh;
  std::vector<Support> supports;
  bool gravity = false;   ///< the fully drained sag load ρ_csf g along −z (ccx: *DLOAD GRAV)
  MatrixX3d nodal_force;  ///< further nodal forces, mN (ccx: *CLOAD); empty: none
  std::optional<SkullContact> contact;  ///< TLED's obstacle
  std::vector<Gap> gaps;                ///< ccx's obstacle, the same one node by node
};

std::vector<index_t> nodes_where(const core::TetMesh& m, auto&& pred) {
  std::vector<index_t> out;
  for (index_t i = 0; i < m.num_nodes(); ++i)
    if (pred(Vector3d(m.nodes().row(i).transpose()))) out.push_back(i);
  return out;
}

SagLoad full_weight() {
  SagLoad load;
  load.gravity_direction = {0.0, 0.0, -1.0};
  load.drain_depth = 1e3;  // mm, more than any block here: every node loses its buoyancy
  return load;
}

TledResult solve_tled(const Bench& b) {
  TledProblem p;
  p.external_force = MatrixX3d::Zero(b.mesh.num_nodes(), 3);
  if (b.gravity) p.external_force += sag_nodal_force(b.mesh, full_weight());
  if (b.nodal_force.size() > 0) p.external_force += b.nodal_force;
  for (const Support& s : b.supports)
    for (const index_t i : s.nodes)
      p.constraints.push_back({i, {true, true, true}, s.displacement});
  p.contact = b.contact;
  TledOptions o;
  o.error_tolerance = kTledTolerance;
  o.max_iterations = 2'000'000;
  const TledResult r = TledSolver(b.mesh).solve(p, o);
  EXPECT_EQ(r.status, TledStatus::CONVERGED) << r.message;
  return r;
}

/// The ccx deck of a bench: C3D4, one NEO HOOKE material (C10 = μ/2, D1 = 2/κ) per distinct
/// (E, ν), supports, *DLOAD GRAV and *CLOAD, one GAPUNI element per gap to a fixed ground node;
/// *STATIC NLGEOM with tight convergence controls.
void write_deck(const std::filesystem::path& file, const Bench& b) {
  const core::TetMesh& m = b.mesh;
  std::ofstream out(file);
  out << "*HEADING\nbrainshift test_tled_calculix\n";
  tests::calculix::write_mesh(out, m);
  // ccx reads a number from at most 20 characters: 12 significant digits fit with sign and
  // exponent (1e-12 relative, far below the differences checked here).
  out << std::setprecision(12);
  const index_t n = m.num_nodes(), nt = m.num_tets();
  if (!b.gaps.empty()) {
    out << "*NODE, NSET=GROUND\n";
    for (std::size_t k = 0; k < b.gaps.size(); ++k)
      out << n + 1 + index_t(k) << ", " << b.gaps[k].ground.x() << ", " << b.gaps[k].ground.y()
          << ", " << b.gaps[k].ground.z() << "\n";
    // One element set per gap (each has its own clearance and direction). ccx closes a gap
    // when clearance + direction·(u_ground − u_node) reaches 0.
    for (std::size_t k = 0; k < b.gaps.size(); ++k) {
      const Gap& g = b.gaps[k];
      out << "*ELEMENT, TYPE=GAPUNI, ELSET=G" << k << "\n"
          << nt + 1 + index_t(k) << ", " << g.node + 1 << ", " << n + 1 + index_t(k) << "\n"
          << "*GAP, ELSET=G" << k << "\n"
          << g.clearance << ", " << g.direction.x() << ", " << g.direction.y() << ", "
          << g.direction.z() << ", , " << kGapStiffness << ", " << kGapOpenForce << "\n";
    }
  }
  for (const Support& s : b.supports) write_node_set(out, s.name, s.nodes);
  // Materials: one element set per distinct (E, ν).
  std::vector<std::pair<double, double>> materials;
  std::vector<std::vector<index_t>> members;
  for (index_t t = 0; t < nt; ++t) {
    const std::pair<double, double> key{m.youngs_modulus()(t), m.poisson_ratio()(t)};
    const auto it = std::find(materials.begin(), materials.end(), key);
    if (it == materials.end()) {
      materials.push_back(key);
      members.push_back({t});
    } else {
      members[std::size_t(it - materials.begin())].push_back(t);
    }
  }
  for (std::size_t k = 0; k < materials.size(); ++k) {
    out << "*ELSET, ELSET=M" << k << "\n";
    for (std::size_t j = 0; j < members[k].size(); ++j)
      out << members[k][j] + 1 << ((j % 10 == 9 || j + 1 == members[k].size()) ? "\n" : ", ");
    const NeoHookean mat = NeoHookean::from_youngs(materials[k].first, materials[k].second);
    out << "*MATERIAL, NAME=BRAIN" << k << "\n*HYPERELASTIC, NEO HOOKE\n"
        << 0.5 * mat.mu << ", " << 2.0 / mat.kappa << "\n"
        << "*DENSITY\n"
        << full_weight().csf_density << "\n"
        << "*SOLID SECTION, ELSET=M" << k << ", MATERIAL=BRAIN" << k << "\n";
  }
  // Residual and correction controls 100x tighter than ccx's defaults (0.005, 0.01), so that
  // ccx's own convergence error stays far below the differences bounded here.
  out << "*STEP, NLGEOM, INC=1000\n*CONTROLS, PARAMETERS=FIELD\n5e-5, 1e-4\n"
      << "*STATIC\n0.1, 1.0\n*BOUNDARY\n";
  if (!b.gaps.empty()) out << "GROUND, 1, 3, 0.\n";
  for (const Support& s : b.supports)
    for (int a = 0; a < 3; ++a)
      out << s.name << ", " << a + 1 << ", " << a + 1 << ", " << s.displacement(a) << "\n";
  if (b.gravity) out << "*DLOAD\nEALL, GRAV, " << full_weight().gravity << ", 0., 0., -1.\n";
  if (b.nodal_force.size() > 0) {
    out << "*CLOAD\n";
    for (index_t i = 0; i < n; ++i)
      for (int a = 0; a < 3; ++a)
        if (b.nodal_force(i, a) != 0.0)
          out << i + 1 << ", " << a + 1 << ", " << b.nodal_force(i, a) << "\n";
  }
  out << "*NODE PRINT, NSET=NALL\nU\n*END STEP\n";
}

struct Comparison {
  TledResult tled;
  MatrixX3d ccx;
  double max_difference = 0.0;  ///< mm
  double relative_l2 = 0.0;
  double max_displacement = 0.0;  ///< of ccx's answer, mm
};

Comparison compare(const Bench& b, const std::string& name) {
  Comparison c;
  const tests::TempFolder folder;
  write_deck(folder / (name + ".inp"), b);
  double seconds = 0.0;
  c.ccx = run_ccx(folder.path(), name, b.mesh.num_nodes(), seconds);
  c.tled = solve_tled(b);
  c.max_difference = max_nodal_difference(c.tled.displacement, c.ccx);
  c.relative_l2 = tests::relative_difference(c.tled.displacement, c.ccx);
  c.max_displacement = c.ccx.rowwise().norm().maxCoeff();
  std::cout << "[tled vs ccx] " << name << ": " << b.mesh.num_nodes() << " nodes, "
            << b.mesh.num_tets() << " tets; ccx " << seconds << " s; TLED " << c.tled.iterations
            << " steps, " << c.tled.contact_nodes << " in contact; max |u| " << c.max_displacement
            << " mm; max nodal difference " << c.max_difference << " mm, relative L2 "
            << c.relative_l2 << "\n";
  return c;
}

/// Cube 20 mm, 5 cells a side; base fixed; top face moved 6 mm sideways and 4 mm down (30 %
/// shear, 20 % compression).
Bench sheared_cube() {
  Bench b;
  b.mesh = make_box_mesh({20.0, 20.0, 20.0}, {5, 5, 5});
  b.supports.push_back({"BASE", nodes_where(b.mesh, [](const Vector3d& x) { return x.z() < 1e-9; }),
                        Vector3d::Zero()});
  b.supports.push_back({"TOP",
                        nodes_where(b.mesh, [](const Vector3d& x) { return x.z() > 20.0 - 1e-9; }),
                        Vector3d(6.0, 0.0, -4.0)});
  return b;
}

constexpr double kSpan = 60.0, kWidth = 20.0, kDepth = 20.0;  // mm

/// Block 60 × 20 × 20 mm (12 × 4 × 4 cells), both ends (x = 0, x = 60) clamped, own weight.
Bench sagging_block() {
  Bench b;
  b.mesh = make_box_mesh({kSpan, kWidth, kDepth}, {12, 4, 4});
  b.supports.push_back(
      {"ENDS",
       nodes_where(b.mesh, [](const Vector3d& x) { return x.x() < 1e-9 || x.x() > kSpan - 1e-9; }),
       Vector3d::Zero()});
  b.gravity = true;
  return b;
}

/// Maximum nodal agreement asserted on the blocks, mm. Measured (ccx 2.20): sheared cube 1.7e-6,
/// sagging block 2.5e-5, block on the plane 1.2e-4 mm (relative L2 1.9e-7, 1.6e-6, 3.6e-5). The
/// bound is
/// ten times TLED's stopping tolerance (its estimate is an upper bound of its error within a
/// factor of a few, test_tled_solver.cpp) plus ccx's printed precision (7 digits of ≤ 10 mm
/// displacements: 1e-5 mm) and, with contact, the penalty penetration (≤ 1e-6 mm).
constexpr double kAgreement = 10.0 * kTledTolerance + 1e-5;

TEST(TledCalculix, ShearedCubeMatchesCalculixNeoHookeNlgeom) {
  if (!ccx_available()) GTEST_SKIP() << "ccx (CalculiX, Debian package calculix-ccx) not on PATH";
  const Comparison c = compare(sheared_cube(), "shear");
  EXPECT_GT(c.max_displacement, 7.0);  // the prescribed 7.2 mm: a finite-strain case
  EXPECT_LE(c.max_difference, kAgreement);
}

TEST(TledCalculix, SaggingBlockMatchesCalculixWithoutContact) {
  if (!ccx_available()) GTEST_SKIP() << "ccx (CalculiX, Debian package calculix-ccx) not on PATH";
  const Comparison c = compare(sagging_block(), "sag");
  EXPECT_GT(c.max_displacement, 3.0);  // large enough for the plane test below to bite
  EXPECT_LE(c.max_difference, kAgreement);
}

TEST(TledCalculix, SaggingBlockOnARigidPlaneMatchesCalculixFrictionlessContact) {
  if (!ccx_available()) GTEST_SKIP() << "ccx (CalculiX, Debian package calculix-ccx) not on PATH";
  Bench b = sagging_block();
  constexpr double kPlaneLevel = -2.0;  // mm below the bottom face: about half the free sag
  const std::vector<index_t> candidates = nodes_where(b.mesh, [](const Vector3d& x) {
    return x.z() < 1e-9 && x.x() > 1e-9 && x.x() < kSpan - 1e-9;
  });
  SkullContact plane;  // see the file comment: an ellipsoid flat enough to be the plane
  constexpr double kFlat = 1e6, kThick = 100.0;  // mm
  plane.skull.semi_axes = {kFlat, kFlat, kThick};
  plane.skull.centre = {0.5 * kSpan, 0.5 * kWidth, kPlaneLevel + kThick};
  plane.candidate_nodes = candidates;
  b.contact = plane;
  for (const index_t i : candidates) {
    const Vector3d x = b.mesh.nodes().row(i).transpose();
    b.gaps.push_back({i, -Vector3d::UnitZ(), x.z() - kPlaneLevel, {x.x(), x.y(), kPlaneLevel}});
  }
  const Comparison c = compare(b, "contact");
  EXPECT_GT(c.tled.contact_nodes, 0);
  // Neither answer goes through the plane (TLED: by projection, to the closest-point solver's
  // 1e-6 mm; ccx: by the penalty, ≤ 1e-6 mm, plus its printed precision).
  index_t ccx_on_plane = 0;
  for (const index_t i : candidates) {
    const double z_tled = b.mesh.nodes()(i, 2) + c.tled.displacement(i, 2);
    const double z_ccx = b.mesh.nodes()(i, 2) + c.ccx(i, 2);
    EXPECT_GE(z_tled, kPlaneLevel - 1e-5) << "node " << i;
    EXPECT_GE(z_ccx, kPlaneLevel - 1e-5) << "node " << i;
    ccx_on_plane += z_ccx < kPlaneLevel + 1e-4 ? 1 : 0;
  }
  EXPECT_GT(ccx_on_plane, 0);
  EXPECT_LE(c.max_difference, kAgreement);
}

/// The default phantom, coarse (8 mm cells), under the load of every phantom case
/// (make_sag_problem: CSF drained 60 mm below the top, base fixed, frictionless skull contact
/// except under the craniotomy). ccx's skull is one gap per candidate node, along the skull's
/// normal at the closest skull point of the node's position (a tangent plane per node, where TLED
/// projects onto the curved skull), taken from a first ccx pass with the rest positions and
/// solved again. Both sides get the same candidates: the surface nodes
/// inside the skull at rest and not under the opening. (The surface nodes that start outside the
/// skull, unsnapped stair corners of the voxel mesh, are left free here: TLED pulls them onto the
/// skull in its first steps, which ccx's penalty gaps cannot follow from an initial overclosure
/// of up to 4 mm; 164 of 1087 at this cell size.)
TEST(TledCalculix, CoarsePhantomSagWithSkullContactMatchesCalculix) {
  if (!ccx_available()) GTEST_SKIP() << "ccx (CalculiX, Debian package calculix-ccx) not on PATH";
  const PhantomGeometry g;
  PhantomMeshOptions mo;
  mo.cell_size = 8.0;  // mm
  const PhantomMesh pm = make_phantom_mesh(g, mo);
  const TledProblem sag = make_sag_problem(g, pm, SagLoad{});
  ASSERT_TRUE(sag.contact.has_value());
  Bench b;
  b.mesh = pm.mesh;
  b.supports.push_back({"BASE", pm.base_nodes, Vector3d::Zero()});
  b.nodal_force = sag.external_force;
  SkullContact skull = *sag.contact;
  std::vector<index_t> candidates;
  for (const index_t i : skull.candidate_nodes) {
    const Vector3d x = b.mesh.nodes().row(i).transpose();
    const Vector3d q = skull.skull.closest_point(x);
    if (skull.skull.level(x) > 1.0 || (q - skull.opening_centre).norm() < skull.opening_radius)
      continue;
    const Vector3d normal = skull.skull.normal(q);
    candidates.push_back(i);
    b.gaps.push_back({i, normal, (q - x).dot(normal), q});
  }
  ASSERT_GT(candidates.size(), skull.candidate_nodes.size() / 2);
  skull.candidate_nodes = candidates;
  b.contact = skull;
  {  // ccx's second pass: each node's plane tangent where ccx's first pass put the node.
    const tests::TempFolder folder;
    write_deck(folder / "phantom1.inp", b);
    double seconds = 0.0;
    const MatrixX3d u1 = run_ccx(folder.path(), "phantom1", b.mesh.num_nodes(), seconds);
    for (Gap& gap : b.gaps) {
      const Vector3d x = b.mesh.nodes().row(gap.node).transpose();
      const Vector3d q = skull.skull.closest_point(x + u1.row(gap.node).transpose());
      gap.direction = skull.skull.normal(q);
      gap.clearance = (q - x).dot(gap.direction);
      gap.ground = q;
    }
  }
  const Comparison c = compare(b, "phantom");
  EXPECT_GT(c.tled.contact_nodes, 0);
  EXPECT_GT(c.max_displacement, 5.0);  // the cortical shift of the phantom cases
  // ccx's skull is, per node, the plane tangent to the skull where ccx's first pass left the
  // node; TLED's is the curved ellipsoid. The difference is of the order of (the slide between
  // the two passes)² / (2 × skull radius ≈ 70 mm), plus nodes near the opening's rim that one
  // side frees and the other holds. Measured (ccx 2.20, this mesh): max nodal 0.10 mm, relative L2
  // 4.8e-3 (one pass with rest-position planes: 0.68 mm, 4.2e-2, so the second pass matters).
  // Bounds: 2.5x the measurement for the worst node (a quarter of the 1 mm registration target)
  // and 2x for L2.
  constexpr double kCurvedSkullMax = 0.25;  // mm
  constexpr double kCurvedSkullRel = 1e-2;
  EXPECT_LE(c.max_difference, kCurvedSkullMax);
  EXPECT_LE(c.relative_l2, kCurvedSkullRel);
}

}  // namespace
}  // namespace brainshift::data_synth
