#pragma once
/// @file
/// @brief Register-and-write: one intra-operative registration against a prepared MODEL, as
/// `brainshift register` runs it — load the model (session.hpp), extract the vessel points from
/// the power Doppler and the footprint from the B-mode, run the constraint-based ICP, write the
/// result folder (result_report.hpp). Inputs in world RAS, mm; results in the intra-operative
/// frame (result_fields.hpp).

#include "apps/workflow/progress.hpp"
#include "constraints/registration/registration.hpp"

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace brainshift::workflow {

/// What to register and where to write it (the flags of `brainshift register`).
struct RegisterOptions {
  std::filesystem::path model;                 ///< MODEL folder from prepare
  std::filesystem::path doppler;               ///< power-Doppler volume (vessels)
  std::optional<std::filesystem::path> bmode;  ///< B-mode volume (probe footprint), optional
  std::optional<std::filesystem::path> mri;    ///< pre-operative MRI to warp (model's grid)
  /// Power Doppler of a sweep made on the dura before it was opened (no shift yet), in the same
  /// tracked frame: the navigation offset (the rigid pose) is measured from it, and the sweep
  /// after opening only adds the deformation (constraints::IntraopData::pose). Without it, the
  /// pose is searched in the post-opening sweep, where it can absorb part of the sag.
  std::optional<std::filesystem::path> pre_dura;
  /// The same pose, measured once beforehand and stored (pose_file.hpp: `brainshift pre-dura`, or
  /// RES/pre_dura_pose.json of a run with `pre_dura`): no second extraction. Not with `pre_dura`.
  std::optional<std::filesystem::path> pre_dura_pose;
  /// Landmark pairs to register on besides the images (e.g. a tracked pointer on bifurcations
  /// seen in the MRI): one file of pairs (a two-volume MNI .tag: MRI set first) or two files
  /// (pre-operative, intra-operative), in any format of imaging/io/landmark_files.hpp, paired by
  /// id. Empty: none.
  std::vector<std::filesystem::path> landmarks;
  std::string init;           ///< "rigid", "identity" or empty (the scene's choice)
  std::filesystem::path out;  ///< result folder RES (replaced atomically)
};

/// What register_and_write() did (the full account is RES/report.json).
struct RegisterOutcome {
  constraints::RegistrationResult result;  ///< positions in the model frame, mm
  double max_displacement_mm = 0.0;        ///< largest nodal displacement (model frame)
  /// fixed_base_note() of the result (report.json rigid.fixed_base_moved_mm.note); empty when the
  /// pose was given or moved the fixed base no further than the navigation's accuracy.
  std::string fixed_base_note;
};

/// Loads the model, reads the images, registers and writes RES (report.json and the fields);
/// progress stages go to `progress`. A registration that does not converge is still written
/// (outcome.result.converged says so).
/// \throws brainshift::Error, one line naming the file, for bad inputs (nothing written then).
RegisterOutcome register_and_write(const RegisterOptions& options, const Progress& progress);

}  // namespace brainshift::workflow
