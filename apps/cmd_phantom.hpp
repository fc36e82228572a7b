#pragma once
/// @file
/// @brief `brainshift phantom`: writes a named synthetic phantom case with its known truth
/// (data_synth::generate_case): pre-operative MRI/labels/MRA, intra-operative Doppler/B-mode,
/// truth displacement, landmarks, ventricle surfaces and case.json. Wiring only.

#include <cstdint>
#include <filesystem>
#include <iosfwd>
#include <optional>
#include <string>

namespace CLI {
class App;
}  // namespace CLI

namespace brainshift::apps {

/// Arguments of `brainshift phantom`.
struct PhantomArgs {
  std::string case_name;                             ///< one of data_synth::case_names()
  std::uint32_t seed = 1;
  std::optional<std::filesystem::path> vessels;      ///< user tree (.vtp polylines)
  int frames = 0;                                    ///< intra-operative sequence length
  std::filesystem::path out;                         ///< DIR: new or empty
};

/// Registers the `phantom` subcommand on `app`. `args` is not owned and must outlive `app`.
CLI::App* add_phantom_command(CLI::App& app, PhantomArgs& args);

/// Generates the case; progress lines on stderr, a summary on `out`.
/// @return 0 on success (the truth solve converged), 2 when it stopped without converging (the
/// case is written anyway and says so in case.json).
/// \throws brainshift::Error, one line, for bad inputs (unknown case name listing the valid
/// ones, existing non-empty DIR, unreadable vessel file).
int run_phantom(const PhantomArgs& args, std::ostream& out);

}  // namespace brainshift::apps
