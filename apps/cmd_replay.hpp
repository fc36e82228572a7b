#pragma once
/// @file
/// @brief `brainshift replay`: registers each recorded frame of a sequence in order
/// (DIR/frame_*/doppler.nii.gz, optional bmode.nii.gz), each warm-started from the previous
/// frame's result; a frame that fails is reported and skipped, the rest go on. Writes
/// RES/frame_NNN/ (as `register` does) and RES/replay.json with per-frame reports and the
/// latency summary (median, p95, max). Exit code 0 when every frame registered, 2 when some
/// failed or did not converge, 1 when none registered.

#include <filesystem>
#include <iosfwd>
#include <string>

namespace CLI {
class App;
}  // namespace CLI

namespace brainshift::apps {

struct ReplayArgs {
  std::filesystem::path model;
  std::filesystem::path sequence;
  std::filesystem::path out;
  /// Predicted error per frame: "every" (default), "last" (the last frame folder only) or
  /// "none"; a frame without it has no uncertainty.nii.gz and report `uncertainty` =
  /// {"computed": false}.
  std::string uncertainty = "every";
};

CLI::App* add_replay_command(CLI::App& app, ReplayArgs& args);
int run_replay(const ReplayArgs& args, std::ostream& out);

}  // namespace brainshift::apps
