#pragma once
/// @file
/// @brief `brainshift simulate`: static forward simulation of a .vtu mesh under fixed nodes,
/// prescribed nodal displacements and gravity (core::StaticSolver). Wiring only.

#include <filesystem>
#include <iosfwd>
#include <optional>
#include <vector>

namespace CLI {
class App;
}  // namespace CLI

namespace brainshift::apps {

/// Exit code when the inputs were fine but the solve did not converge.
inline constexpr int exit_not_converged = 2;

/// Arguments of `brainshift simulate`.
struct SimulateArgs {
  std::filesystem::path mesh;                     ///< input .vtu
  std::optional<std::filesystem::path> fixed;     ///< node-list CSV: zero displacement
  std::optional<std::filesystem::path> displace;  ///< node,dx,dy,dz CSV, mm
  std::vector<double> gravity;                    ///< empty or 3 values, mm/s²
  bool linear = false;                            ///< plain linear FEM instead of corotational
  int max_iterations = 200;
  double tolerance = 1e-6;         ///< relative increment tolerance
  bool write_unconverged = false;  ///< write OUT even when the solve fails
  std::filesystem::path out;       ///< output .vtu
};

/// Registers the `simulate` subcommand on `app`, filling `args` on parse.
/// @return the subcommand (true when it was given). `args` is not owned and must outlive `app`.
CLI::App* add_simulate_command(CLI::App& app, SimulateArgs& args);

/// Runs the simulation and prints a summary to `out`.
/// @return 0 when converged and written; exit_not_converged when the solver stopped without
/// converging (then OUT is written only with `write_unconverged`).
/// \throws brainshift::Error, one line, for bad inputs (files, node ids, options), before any
/// output is written.
int run_simulate(const SimulateArgs& args, std::ostream& out);

}  // namespace brainshift::apps
