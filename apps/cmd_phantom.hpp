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
#include <vector>

namespace CLI {
class App;
}  // namespace CLI

namespace brainshift::apps {

/// Arguments of `brainshift phantom`.
struct PhantomArgs {
  std::string case_name;  ///< one of data_synth::case_names()
  std::uint32_t seed = 1;
  std::optional<std::filesystem::path> vessels;  ///< user tree (.vtp polylines)
  int frames = 0;                                ///< intra-operative sequence length
  std::filesystem::path out;                     ///< DIR: new or empty
  /// A label volume (0 background, 1 brain, 2 tumour, 3 ventricles): the case's recipe on its
  /// brain instead of the analytic phantom (data_synth/cases/label_case.hpp).
  std::optional<std::filesystem::path> labels;
  std::vector<double> tumour;      ///< X,Y,Z,RADIUS (mm, world RAS), with --labels
  std::vector<double> craniotomy;  ///< X,Y,Z (mm, world RAS), with --labels
};

/// Registers the `phantom` subcommand on `app`. `args` is not owned and must outlive `app`.
CLI::App* add_phantom_command(CLI::App& app, PhantomArgs& args);

/// Generates the case; progress lines on stderr, a summary on `out`.
/// @return 0 on success (the truth solve converged), 2 when it stopped without converging (the
/// case is written anyway and says so in case.json).
/// \throws brainshift::Error, one line, for bad inputs (unknown case name listing the valid
/// ones, existing non-empty DIR, unreadable vessel file; with --labels: unreadable labels, no
/// brain, a tumour or craniotomy outside the brain, --tumour/--craniotomy without --labels).
int run_phantom(const PhantomArgs& args, std::ostream& out);

}  // namespace brainshift::apps
