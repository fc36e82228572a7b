#include "cmd_demo.hpp"

#include <CLI/CLI.hpp>

#include <cmath>
#include <ostream>
#include <system_error>
#include <vector>

#include "cmd_simulate.hpp"
#include "core/error.hpp"
#include "core/solver/static_solver.hpp"
#include "data_synth/geometry/structured_mesh.hpp"
#include "imaging/io/csv.hpp"
#include "imaging/io/mesh_io.hpp"

namespace brainshift::apps {
namespace {

constexpr double radius = 20.0;     // mm
constexpr double length = 80.0;     // mm
constexpr int radial_cells = 8;     // 9 × 9 nodes per cross-section
constexpr int axial_cells = 24;     // 25 cross-sections: 2025 nodes
const Vector3d top_displacement(10.0, 0.0, 0.0);  // mm, sideways

/// Nodes whose z is within a rounding tolerance of `z` (mm).
std::vector<index_t> nodes_at_height(const core::TetMesh& mesh, double z) {
  std::vector<index_t> nodes;
  for (index_t i = 0; i < mesh.num_nodes(); ++i)
    if (std::abs(mesh.nodes()(i, 2) - z) < 1e-9 * length) nodes.push_back(i);
  return nodes;
}

}  // namespace

CLI::App* add_demo_command(CLI::App& app, DemoArgs& args) {
  CLI::App* cmd = app.add_subcommand(
      "demo", "Self-contained demo, no data needed: bends a cylinder fixed at its base");
  cmd->add_option("--out", args.out, "Output folder (created if missing)")->capture_default_str();
  return cmd;
}

int run_demo(const DemoArgs& args, std::ostream& out) {
  std::error_code ec;
  std::filesystem::create_directories(args.out, ec);
  BS_VERIFY(!ec, "cannot create the output folder " << args.out.string() << ": " << ec.message());

  const core::TetMesh mesh =
      data_synth::make_cylinder_mesh(radius, length, radial_cells, axial_cells);
  const std::vector<index_t> base = nodes_at_height(mesh, 0.0);
  std::vector<core::PrescribedDisplacement> top;
  for (const index_t n : nodes_at_height(mesh, length)) top.push_back({n, top_displacement});

  SimulateArgs sim;
  sim.mesh = args.out / "mesh.vtu";
  sim.fixed = args.out / "fixed.csv";
  sim.displace = args.out / "displace.csv";
  sim.out = args.out / "result.vtu";
  imaging::write_tet_mesh(sim.mesh, mesh);
  imaging::write_node_list(*sim.fixed, base);
  imaging::write_node_displacements(*sim.displace, top);
  out << "brainshift demo: cylinder r = " << radius << " mm, length " << length
      << " mm, base fixed (" << base.size() << " nodes), top (" << top.size()
      << " nodes) moved by (" << top_displacement.transpose() << ") mm\n";
  const int code = run_simulate(sim, out);
  out << "Re-run with: brainshift simulate --mesh " << sim.mesh.string() << " --fixed "
      << sim.fixed->string() << " --displace " << sim.displace->string() << " --out "
      << sim.out.string() << '\n';
  return code;
}

}  // namespace brainshift::apps
