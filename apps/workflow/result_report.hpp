#pragma once
/// @file
/// @brief The report writers of a registration: report.json's content (registration_report,
/// result_report) and the result folder RES written atomically (write_result): report.json,
/// deformed.vtu, displacement.nii.gz, preop_to_intraop.nrrd, intraop_to_preop.nrrd,
/// uncertainty.nii.gz, warped_mri.nii.gz, overlay.png; fields in the intra-operative frame
/// (result_fields.hpp), mm, world RAS.

#include "apps/workflow/session.hpp"
#include "constraints/registration/registration.hpp"
#include "imaging/io/volume.hpp"

#include <nlohmann/json.hpp>

#include <filesystem>

namespace brainshift::workflow {

/// Writes RES (report.json, deformed.vtu, displacement.nii.gz, preop_to_intraop.nrrd,
/// intraop_to_preop.nrrd, overlay.png, warped_mri.nii.gz with an MRI from read_preop_mri())
/// atomically. `extra` is merged into the report. Without `with_uncertainty` the predicted
/// error is skipped: no uncertainty.nii.gz, report `uncertainty` = {"computed": false}.
/// With `threads` ≥ 2 the fields are computed on two threads and each file is written as soon as
/// its field is there (compute_result_fields() with a callback); the files are the same bytes
/// as with `threads` = 1 (all in turn), only report.json's times differ.
void write_result(const std::filesystem::path& res, const Session& s,
                  const constraints::RegistrationResult& r, const IntraopInputs& in,
                  const imaging::VolumeF* mri, const nlohmann::json& extra,
                  bool with_uncertainty = true, int threads = 2);

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

/// A 4×4 matrix as four rows of four numbers (a rigid transform in the reports).
nlohmann::json matrix_json(const Eigen::Matrix4d& m);

}  // namespace brainshift::workflow
