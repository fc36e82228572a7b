#pragma once
/// @file
/// @brief `brainshift demo`: a self-contained run needing no data. For now the small forward
/// simulation: a cylinder (radius 20 mm, length 80 mm, ≈2k nodes) fixed at its base with its top
/// pushed 10 mm sideways. Writes its inputs next to its result, so the same case can be re-run
/// with `brainshift simulate`. Wiring only.

#include <filesystem>
#include <iosfwd>

namespace CLI {
class App;
}  // namespace CLI

namespace brainshift::apps {

/// Arguments of `brainshift demo`.
struct DemoArgs {
  std::filesystem::path out = "brainshift_demo_out";  ///< output folder, created if missing
};

/// Registers the `demo` subcommand on `app`. `args` is not owned and must outlive `app`.
CLI::App* add_demo_command(CLI::App& app, DemoArgs& args);

/// Writes OUT/mesh.vtu, OUT/fixed.csv, OUT/displace.csv, runs `simulate` on them into
/// OUT/result.vtu and prints a summary to `out`.
/// @return the exit code of the simulation (0 when converged).
int run_demo(const DemoArgs& args, std::ostream& out);

}  // namespace brainshift::apps
