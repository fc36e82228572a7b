#pragma once
/// @file
/// @brief The stored navigation offset: the rigid pose measured once on a power-Doppler sweep made
/// on the dura before it was opened (`brainshift pre-dura`, or written by `register --pre-dura`
/// as RES/pre_dura_pose.json), read back by every later `register` / `replay` with
/// `--pre-dura-pose FILE` so the sweep is not extracted again.
///
/// File format (JSON, version 1):
///   format              "brainshift-pose"
///   version             1
///   frame               a sentence: world RAS, mm; p_model = model_from_intraop · p_intraop
///   model_from_intraop  4×4 row-major rigid transform (rotation, translation in mm): the tracked
///                       (intra-operative) frame into the model's pre-operative frame
///   preop_grid          the grid of the model's labels (model.json), so that a pose measured for
///                       another patient or another scan is refused
///   pre_dura            what was measured: the Doppler file, its vessel points, translation_mm,
///                       rotation_deg, rms_before_mm, rms_after_mm, accepted, message
/// A pose holds for one tracker set-up: the same reference frame (patient tracker) as the sweeps
/// registered with it. If the reference moves, measure it again.

#include "apps/workflow/session.hpp"

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <optional>

namespace brainshift::workflow {

inline constexpr const char* pose_format = "brainshift-pose";
inline constexpr int pose_version = 1;
inline constexpr const char* pose_file_name = "pre_dura_pose.json";  ///< in a result folder

/// A pose read from a file.
struct StoredPose {
  Eigen::Isometry3d model_from_intraop = Eigen::Isometry3d::Identity();
  nlohmann::json pre_dura;  ///< what was measured (the file's `pre_dura`)
};

/// The file's JSON for a pose measured by pose_from_pre_dura() (`report` is what it filled in).
nlohmann::json pose_json(const Session& s, const Eigen::Isometry3d& model_from_intraop,
                         const nlohmann::json& report);

/// Writes pose_json() to `path` atomically (temporary name, then rename).
/// \throws brainshift::Error naming the file when it cannot be written.
void write_pose_file(const std::filesystem::path& path, const nlohmann::json& pose);

/// Reads a pose file and checks it: format and version, a 4×4 matrix of finite numbers whose
/// upper-left block is a rotation (orthonormal to 1e-6, determinant +1) and last row 0 0 0 1, a
/// translation under 1 m, and, when `s` is given, that it was measured for this model's grid.
/// \throws brainshift::Error, one line naming the file and the problem.
StoredPose read_pose_file(const std::filesystem::path& path, const Session* s = nullptr);

/// The navigation offset the flags give: measured on the pre-dura Doppler `pre_dura`
/// (pose_from_pre_dura()), or read from the stored `pose_file` (read_pose_file(), checked
/// against this model); none when neither is given. `report` gets what was measured or read
/// (report.json → intraop.pre_dura: `model_from_intraop`, `source` "measured" or "pose_file",
/// and the measurement's fields); `measured` gets the pose file's JSON when it was measured
/// here (to store it beside the result), and stays null otherwise.
/// 	hrows brainshift::Error, one line, when both are given, or as the two functions do.
std::optional<Eigen::Isometry3d> given_pose(const Session& s,
                                            const std::optional<std::filesystem::path>& pre_dura,
                                            const std::optional<std::filesystem::path>& pose_file,
                                            const constraints::RegistrationOptions& options,
                                            nlohmann::json& report, nlohmann::json& measured);

}  // namespace brainshift::workflow
