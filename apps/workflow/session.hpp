#pragma once
/// @file
/// @brief A prepared MODEL opened for intra-operative work (Session) and the intra-operative
/// inputs read from the images, in the model's (pre-operative) frame: what `register`, `replay`,
/// `bench` and the Slicer module BrainshiftRegister share. Positions in mm, world RAS.

#include "apps/workflow/intraop_footprint.hpp"
#include "apps/workflow/model_folder.hpp"
#include "constraints/registration/registration.hpp"
#include "imaging/io/volume.hpp"
#include "imaging/vessels/vessel_extraction.hpp"

#include <nlohmann/json.hpp>

#include <exception>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>

namespace brainshift::workflow {

/// A prepared model ready for intra-operative work (loaded once, reused by replay).
struct Session {
  LoadedModel loaded;
  std::unique_ptr<constraints::RegistrationModel> model;
  double seconds_load = 0.0;
  nlohmann::json model_report;  ///< how the model was set up (compliance strategy, cache status)
};
/// Loads MODEL and prepares it for registration, adopting MODEL/compliance.bin when it is
/// present and belongs to this model (else the block is recomputed and the report says why; a
/// stale or damaged cache is a warning, not an error: it only costs time).
Session open_session(const std::filesystem::path& model_dir);

/// Intra-operative data from the images, in the model's frame. Throws (one line naming the
/// file) for an unreadable, empty, all-NaN or non-overlapping Doppler volume.
struct IntraopInputs {
  constraints::IntraopData data;
  nlohmann::json report;  ///< what extraction found (counts, thresholds)
  double seconds = 0.0;
  /// A pose measured on a pre-dura sweep for this registration (pose_file.hpp's JSON): written
  /// beside the result as RES/pre_dura_pose.json, for later runs' `--pre-dura-pose`. Null: none.
  nlohmann::json measured_pose;
};
/// `vessels`: extraction settings (the defaults suit the intra-operative Doppler).
IntraopInputs read_intraop(const Session& s, const std::filesystem::path& doppler,
                           const std::optional<std::filesystem::path>& bmode,
                           const imaging::VesselExtractionOptions& vessels = {});

/// A power-Doppler volume read and its vessels extracted, before anything is checked against a
/// model: the model-independent part of read_intraop(), so that it can run while the model loads.
struct DopplerExtraction {
  std::filesystem::path file;
  imaging::ImageGeometry geometry;          ///< the volume's grid (world RAS, mm)
  imaging::VesselExtractionResult vessels;  ///< what extraction found
  std::exception_ptr failure;  ///< thrown by the extraction; rethrown after the overlap check
  double seconds = 0.0;        ///< reading and extraction, s
};
/// Reads `doppler` and extracts its vessels (no model needed).
/// \throws brainshift::Error naming the file when it cannot be read or is not a scalar volume;
/// an error of the extraction itself is kept in DopplerExtraction::failure (read_intraop()
/// reports it after checking that the volume overlaps the model, as a serial run does).
DopplerExtraction extract_doppler(const std::filesystem::path& doppler,
                                  const imaging::VesselExtractionOptions& vessels = {});
/// The same from a volume in memory (e.g. received over OpenIGTLink); `name` stands for the file
/// in messages and reports. \throws brainshift::Error naming `name` when it is not scalar.
DopplerExtraction extract_doppler(const imaging::VolumeF& doppler, const std::string& name,
                                  const imaging::VesselExtractionOptions& vessels = {});
/// read_intraop() from an extraction made beforehand: the same checks in the same order (overlap
/// with the model, then the extraction's outcome), the same result; IntraopInputs::seconds
/// includes DopplerExtraction::seconds.
IntraopInputs read_intraop(const Session& s, const DopplerExtraction& doppler,
                           const std::optional<std::filesystem::path>& bmode);
/// As above with the B-mode in memory (`bmode_name` stands for its file; null: no B-mode).
IntraopInputs read_intraop(const Session& s, const DopplerExtraction& doppler,
                           const imaging::VolumeF* bmode, const std::string& bmode_name);
/// As above with the B-mode's footprint already extracted (footprint_from_bmode(); null: none),
/// e.g. once for several Doppler volumes registered with the same B-mode.
IntraopInputs read_intraop(const Session& s, const DopplerExtraction& doppler,
                           const IntraopFootprint* footprint);

/// The navigation offset (model ← tracked frame) from the power Doppler of a sweep made on the
/// dura before it was opened: its vessel points' rigid global start
/// (constraints::pre_dura_pose()). The identity when no pose scores better than it (the
/// navigation is right). `report` gets the file, points, transform and message.
/// \throws brainshift::Error naming the file when it has too few vessel points for a pose.
Eigen::Isometry3d pose_from_pre_dura(const Session& s, const std::filesystem::path& doppler,
                                     const constraints::RegistrationOptions& options,
                                     nlohmann::json& report);
/// As above from a pre-dura Doppler already extracted (extract_doppler()).
Eigen::Isometry3d pose_from_pre_dura(const Session& s, const DopplerExtraction& doppler,
                                     const constraints::RegistrationOptions& options,
                                     nlohmann::json& report);

/// Reads the pre-operative MRI to warp and checks it lies on the model's grid (same patient and
/// scan). \throws brainshift::Error naming the file otherwise.
imaging::VolumeF read_preop_mri(const Session& s, const std::filesystem::path& mri);
/// As above with the MRI already read from `mri` (e.g. while the model loaded).
imaging::VolumeF read_preop_mri(const Session& s, const std::filesystem::path& mri,
                                imaging::VolumeF image);

}  // namespace brainshift::workflow
