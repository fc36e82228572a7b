#pragma once
/// @file
/// @brief `brainshift pre-dura`: the navigation offset measured once on the power Doppler of a
/// sweep made on the dura before it was opened, stored as a pose file (apps/workflow/pose_file.hpp)
/// that every later `register` / `replay` takes with `--pre-dura-pose`, without extracting the
/// sweep again. World RAS, mm.

#include <filesystem>
#include <iosfwd>

namespace CLI {
class App;
}  // namespace CLI

namespace brainshift::apps {

/// The flags of `brainshift pre-dura`.
struct PreDuraArgs {
  std::filesystem::path model;    ///< MODEL folder from prepare
  std::filesystem::path doppler;  ///< power Doppler of the sweep on the closed dura
  std::filesystem::path out;      ///< the pose file (JSON), written atomically
};

CLI::App* add_pre_dura_command(CLI::App& app, PreDuraArgs& args);
/// Measures the pose, writes it and prints one line. @return 0.
int run_pre_dura(const PreDuraArgs& args, std::ostream& out);

}  // namespace brainshift::apps
