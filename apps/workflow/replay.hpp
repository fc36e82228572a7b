#pragma once
/// @file
/// @brief Replay: registers each recorded frame of a sequence in order (DIR/frame_*/doppler.nii.gz,
/// optional bmode.nii.gz), each warm-started from the previous converged frame's result; a frame
/// that fails is reported and skipped, the rest go on. Writes RES/frame_NNN/ (as register does,
/// result_report.hpp) and RES/replay.json with per-frame reports and the latency summary
/// (median, p95, max; seconds). What `brainshift replay` runs.

#include "apps/workflow/progress.hpp"

#include <nlohmann/json.hpp>

#include <filesystem>
#include <optional>
#include <string>

namespace brainshift::workflow {

/// The inputs of replay (the flags of `brainshift replay`).
struct ReplayOptions {
  std::filesystem::path model;     ///< MODEL folder from prepare
  std::filesystem::path sequence;  ///< folder of frame_*/ (doppler.nii.gz, optional bmode.nii.gz)
  std::filesystem::path out;       ///< result folder RES (replaced atomically)
  /// Predicted error per frame: "every" (default), "last" (the last frame folder only) or
  /// "none"; a frame without it has no uncertainty.nii.gz and report `uncertainty` =
  /// {"computed": false}.
  std::string uncertainty = "every";
  /// Power Doppler of a sweep made on the dura before it was opened: the navigation offset is
  /// measured on it once and given to every frame (constraints::IntraopData::pose; as
  /// `register --pre-dura`). replay.json → `pre_dura` says what was measured.
  std::optional<std::filesystem::path> pre_dura;
  /// The same pose stored beforehand (pose_file.hpp; `register --pre-dura-pose`). Not with
  /// `pre_dura`. A pose measured here is stored as RES/pre_dura_pose.json.
  std::optional<std::filesystem::path> pre_dura_pose;
};

/// What replay did (replay.json's content and its counts).
struct ReplayResult {
  nlohmann::json summary;  ///< RES/replay.json: model, sequence, frames[], latency_s, counts
  int frames = 0;          ///< frame_* folders found
  int failed = 0;          ///< frames that threw (reported, skipped)
  int unconverged = 0;     ///< frames registered without meeting the convergence test
};

/// Registers every frame and writes RES. \throws brainshift::Error, one line, when the sequence
/// folder is missing or has no frame_* folders, the model cannot be opened, or RES cannot be
/// written (a frame's own failure is recorded in the summary instead).
ReplayResult replay_sequence(const ReplayOptions& args, const Progress& progress);

}  // namespace brainshift::workflow
