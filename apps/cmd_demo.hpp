#pragma once
/// @file
/// @brief `brainshift demo`: the surgical session on built-in data — phantom `standard` (truth
/// from a neo-Hookean TLED model), prepare, the navigation offset measured on the sweep over the
/// closed dura and stored (`pre-dura`), register the sweep after opening with that pose, evaluate
/// at the landmarks and over the whole brain (points of the phantom's truth field) — beside the
/// same sweep registered alone, and a short summary: time per stage, errors before → after, the
/// largest deformation, where the outputs are. Wiring only.

#include <cstdint>
#include <filesystem>
#include <iosfwd>

namespace CLI {
class App;
}  // namespace CLI

namespace brainshift::apps {

struct DemoArgs {
  std::filesystem::path out = "brainshift_demo_out";  ///< output folder, created if missing
  std::uint32_t seed = 1;                             ///< phantom seed
};

CLI::App* add_demo_command(CLI::App& app, DemoArgs& args);

/// Runs the demo; DEMO/{phantom,model,result,result_one_sweep,pre_dura_pose.json} are replaced if
/// they exist.
/// @return 0 when every stage ran (a registration that stopped at its iteration cap is reported
/// in the summary, not as a failure: the demo shows the workflow and its numbers).
int run_demo(const DemoArgs& args, std::ostream& out);

}  // namespace brainshift::apps
