#pragma once
/// @file
/// @brief `brainshift register`: one intra-operative registration against a prepared MODEL —
/// vessel points from the power Doppler, footprint from the B-mode, the constraint-based ICP,
/// and the outputs (report.json, deformed.vtu, displacement.nii.gz, preop_to_intraop.nrrd,
/// intraop_to_preop.nrrd, warped_mri.nii.gz, overlay.png; the fields in result_fields.hpp). Wiring
/// only; the pieces are reused by `replay` and `demo`.

#include "model_folder.hpp"

#include "constraints/registration/registration.hpp"
#include "imaging/io/volume.hpp"
#include "imaging/vessels/vessel_extraction.hpp"

#include <nlohmann/json.hpp>

#include <filesystem>
#include <iosfwd>
#include <optional>
#include <string>

namespace CLI {
class App;
}  // namespace CLI

namespace brainshift::apps {

struct RegisterArgs {
  std::filesystem::path model;
  std::filesystem::path doppler;
  std::optional<std::filesystem::path> bmode;
  std::optional<std::filesystem::path> mri;
  std::string init;  ///< "rigid", "identity" or empty (the scene's choice)
  std::filesystem::path out;
};

CLI::App* add_register_command(CLI::App& app, RegisterArgs& args);
int run_register(const RegisterArgs& args, std::ostream& out);

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
};
/// `vessels`: extraction settings (the defaults suit the intra-operative Doppler).
IntraopInputs read_intraop(const Session& s, const std::filesystem::path& doppler,
                           const std::optional<std::filesystem::path>& bmode,
                           const imaging::VesselExtractionOptions& vessels = {});

/// Reads the pre-operative MRI to warp and checks it lies on the model's grid (same patient and
/// scan). \throws brainshift::Error naming the file otherwise.
imaging::VolumeF read_preop_mri(const Session& s, const std::filesystem::path& mri);

/// Writes RES (report.json, deformed.vtu, displacement.nii.gz, preop_to_intraop.nrrd,
/// intraop_to_preop.nrrd, overlay.png, warped_mri.nii.gz with an MRI from read_preop_mri())
/// atomically. `extra` is merged into the report. Without `with_uncertainty` the predicted
/// error is skipped: no uncertainty.nii.gz, report `uncertainty` = {"computed": false}.
void write_result(const std::filesystem::path& res, const Session& s,
                  const constraints::RegistrationResult& r, const IntraopInputs& in,
                  const imaging::VolumeF* mri, const nlohmann::json& extra,
                  bool with_uncertainty = true);

struct ResultFields;
/// As above with the fields already computed (compute_result_fields() with the same `mri`);
/// `seconds_fields` is added to the report's output time.
void write_result(const std::filesystem::path& res, const Session& s,
                  const constraints::RegistrationResult& r, const IntraopInputs& in,
                  const imaging::VolumeF* mri, const ResultFields& fields,
                  const nlohmann::json& extra, double seconds_fields);

/// report.json without its output timing: registration_report(), the intra-operative inputs,
/// `extra` (merged), the model set-up and the load / extraction times.
nlohmann::json result_report(const Session& s, const constraints::RegistrationResult& r,
                             const IntraopInputs& in, const nlohmann::json& extra);

/// Everything in report.json about the registration itself.
nlohmann::json registration_report(const constraints::RegistrationResult& r);

}  // namespace brainshift::apps
