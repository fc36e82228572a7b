#include "cmd_simulate.hpp"

#include "core/error.hpp"
#include "core/solver/static_solver.hpp"
#include "core/timing.hpp"
#include "imaging/io/atomic_write.hpp"
#include "imaging/io/csv.hpp"
#include "imaging/io/mesh_io.hpp"

#include <CLI/CLI.hpp>

#include <iostream>
#include <set>

namespace brainshift::apps {
namespace {

using core::Clock;

using core::seconds_since;

/// Dirichlet nodes (sorted, unique) = fixed ∪ displaced; a node in both is an error.
std::vector<index_t> dirichlet_nodes(const SimulateArgs& args, const std::vector<index_t>& fixed,
                                     const std::vector<core::PrescribedDisplacement>& displaced) {
  std::set<index_t> nodes(fixed.begin(), fixed.end());
  for (const auto& d : displaced) {
    BS_VERIFY(!nodes.contains(d.node), "node " << d.node << " is both fixed (in "
                                               << args.fixed->string() << ") and displaced (in "
                                               << args.displace->string() << ")");
  }
  for (const auto& d : displaced) nodes.insert(d.node);
  BS_VERIFY(!nodes.empty(),
            "no Dirichlet nodes: give --fixed and/or --displace; a body held nowhere has no "
            "static equilibrium");
  return {nodes.begin(), nodes.end()};
}

core::StaticOptions solver_options(const SimulateArgs& args) {
  core::StaticOptions options;
  options.max_iterations = args.max_iterations;
  options.increment_tolerance = args.tolerance;
  options.corotational = !args.linear;
  if (!args.gravity.empty()) {
    BS_VERIFY(args.gravity.size() == 3,
              "--gravity takes 3 values gx,gy,gz (mm/s^2), got " << args.gravity.size());
    options.gravity = Vector3d(args.gravity[0], args.gravity[1], args.gravity[2]);
  }
  const std::string invalid = options.validate();
  BS_VERIFY(invalid.empty(), "invalid solver options: " << invalid);
  return options;
}

void print_summary(std::ostream& out, const core::StaticResult& r, double setup_s, double solve_s) {
  const double max_u = r.displacement.size() > 0 ? r.displacement.rowwise().norm().maxCoeff() : 0;
  out << "  status:            " << core::to_string(r.status) << " (" << r.message << ")\n"
      << "  iterations:        " << r.iterations << '\n'
      << "  final increment:   " << r.final_increment << " mm\n"
      << "  final residual:    " << r.final_residual << '\n'
      << "  inverted elements: " << r.inverted_elements << '\n'
      << "  max displacement:  " << max_u << " mm\n"
      << "  wall time:         " << setup_s + solve_s << " s (setup " << setup_s << " s, solve "
      << solve_s << " s)\n";
}

}  // namespace

CLI::App* add_simulate_command(CLI::App& app, SimulateArgs& args) {
  CLI::App* cmd = app.add_subcommand(
      "simulate", "Static forward simulation: fixed nodes, prescribed displacements, gravity");
  cmd->add_option("--mesh", args.mesh, "Input tetrahedral mesh (.vtu, mm)")->required();
  cmd->add_option("--fixed", args.fixed, "CSV of fixed nodes (header 'node')");
  cmd->add_option("--displace", args.displace,
                  "CSV of prescribed displacements (header 'node,dx,dy,dz', mm)");
  cmd->add_option("--gravity", args.gravity, "Body acceleration gx,gy,gz in mm/s^2, e.g. 0,0,-9810")
      ->delimiter(',')
      ->expected(3);
  cmd->add_flag("--linear", args.linear, "Plain linear FEM instead of corotational");
  cmd->add_option("--max-iterations", args.max_iterations, "Cap on corotational iterations")
      ->capture_default_str();
  cmd->add_option("--tolerance", args.tolerance,
                  "Stop when max |dx| < tolerance * max(1 mm, max |u|)")
      ->capture_default_str();
  cmd->add_flag("--write-unconverged", args.write_unconverged,
                "Write OUT even when the solve does not converge (exit code is still 2)");
  cmd->add_option("--out", args.out, "Output .vtu: rest mesh + point array 'displacement' (mm)")
      ->required();
  return cmd;
}

int run_simulate(const SimulateArgs& args, std::ostream& out) {
  const auto start = Clock::now();
  // Inputs first, all checked before any work: options, output folder, mesh, node files.
  const core::StaticOptions options = solver_options(args);
  imaging::verify_writable(args.out);
  const core::TetMesh mesh = imaging::read_tet_mesh(args.mesh);
  const std::vector<index_t> fixed =
      args.fixed ? imaging::read_node_list(*args.fixed, mesh.num_nodes()) : std::vector<index_t>{};
  const std::vector<core::PrescribedDisplacement> displaced =
      args.displace ? imaging::read_node_displacements(*args.displace, mesh.num_nodes())
                    : std::vector<core::PrescribedDisplacement>{};
  const std::vector<index_t> dirichlet = dirichlet_nodes(args, fixed, displaced);

  out << "brainshift simulate: " << args.mesh.string() << " (" << mesh.num_nodes() << " nodes, "
      << mesh.num_tets() << " tetrahedra), " << dirichlet.size() - displaced.size() << " fixed + "
      << displaced.size() << " displaced nodes, " << (args.linear ? "linear" : "corotational")
      << " FEM\n";
  const core::StaticSolver solver(mesh, dirichlet);
  const double setup_s = seconds_since(start);
  const auto solve_start = Clock::now();
  const core::StaticResult result = solver.solve(displaced, options);
  const double solve_s = seconds_since(solve_start);
  print_summary(out, result, setup_s, solve_s);

  const bool converged = result.status == core::SolveStatus::CONVERGED;
  if (converged || args.write_unconverged) {
    imaging::write_tet_mesh(args.out, mesh, &result.displacement);
    out << "  wrote:             " << args.out.string() << '\n';
  }
  if (!converged) {
    std::cerr << "brainshift: error: the solve did not converge: " << core::to_string(result.status)
              << ": " << result.message
              << (args.write_unconverged ? "" : " (nothing written; see --write-unconverged)")
              << '\n';
    return exit_not_converged;
  }
  return 0;
}

}  // namespace brainshift::apps
