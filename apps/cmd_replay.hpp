#pragma once
/// @file
/// @brief `brainshift replay`: registers each recorded frame of a sequence in order
/// (DIR/frame_*/doppler.nii.gz, optional bmode.nii.gz), each warm-started from the previous
/// frame's result; a frame that fails is reported and skipped, the rest go on. Writes
/// RES/frame_NNN/ (as `register` does) and RES/replay.json with per-frame reports and the
/// latency summary (median, p95, max). Exit code 0 when every frame registered, 2 when some
/// failed or did not converge, 1 when none registered. Argument parsing over replay_sequence()
/// (apps/workflow/replay.hpp).

#include "apps/workflow/replay.hpp"

#include <iosfwd>

namespace CLI {
class App;
}  // namespace CLI

namespace brainshift::apps {

/// The flags of `brainshift replay` (workflow/replay.hpp).
using ReplayArgs = workflow::ReplayOptions;

CLI::App* add_replay_command(CLI::App& app, ReplayArgs& args);
int run_replay(const ReplayArgs& args, std::ostream& out);

}  // namespace brainshift::apps
