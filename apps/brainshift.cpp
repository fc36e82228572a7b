// brainshift: brain-shift compensation from the command line.
//
// Subcommands (each has --help):
//   brainshift demo [--out DIR]
//       Self-contained forward simulation (no data needed): writes DIR/mesh.vtu, fixed.csv,
//       displace.csv and result.vtu (default DIR = brainshift_demo_out).
//   brainshift phantom --case NAME [--seed N] [--vessels FILE.vtp] [--frames K] --out DIR
//       Synthetic phantom case with known truth (pre-op MRI/labels/MRA, intra-op Doppler/B-mode,
//       truth displacement and landmarks); an unknown NAME lists the valid ones.
//   brainshift simulate --mesh brain.vtu --fixed fixed.csv --displace displace.csv
//                       [--gravity 0,0,-9810] [--linear] [--max-iterations 200]
//                       [--tolerance 1e-6] [--write-unconverged] --out result.vtu
//       Static corotational FEM under fixed nodes, prescribed displacements (mm) and gravity
//       (mm/s^2); writes the rest mesh with the point array 'displacement' (mm).
//
// Exit codes: 0 success; 1 bad input or any error (one line on stderr:
// "brainshift: error: <message>"); 2 the solve did not converge (see simulate --help);
// command-line syntax errors use CLI11's codes (non-zero).
//
// Units: mm, kg, s (force mN, stress kPa); world frame RAS, mm.

#include <CLI/CLI.hpp>

#include <exception>
#include <iostream>

#include "cmd_demo.hpp"
#include "cmd_phantom.hpp"
#include "cmd_simulate.hpp"
#include "core/error.hpp"

int main(int argc, char** argv) {
  namespace apps = brainshift::apps;
  CLI::App app{"brainshift: brain-shift compensation with a corotational FEM brain model",
               "brainshift"};
  app.require_subcommand(1);
  apps::SimulateArgs simulate_args;
  apps::DemoArgs demo_args;
  const CLI::App* simulate = apps::add_simulate_command(app, simulate_args);
  const CLI::App* demo = apps::add_demo_command(app, demo_args);
  apps::PhantomArgs phantom_args;
  const CLI::App* phantom = apps::add_phantom_command(app, phantom_args);

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::cerr << "brainshift: error: " << e.what() << " (see brainshift --help)\n";
    return e.get_exit_code() != 0 ? e.get_exit_code() : 1;
  }

  try {
    if (simulate->parsed()) return apps::run_simulate(simulate_args, std::cout);
    if (demo->parsed()) return apps::run_demo(demo_args, std::cout);
    if (phantom->parsed()) return apps::run_phantom(phantom_args, std::cout);
  } catch (const brainshift::Error& e) {
    std::cerr << "brainshift: error: " << e.what() << '\n';
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "brainshift: error: " << e.what() << '\n';
    return 1;
  }
  return 1;  // unreachable: require_subcommand(1)
}
