#pragma once
/// @file
/// @brief The descriptions of the two brainshift modules for 3D Slicer (category
/// "Registration.Brain shift") and the checks they share. The executables
/// BrainshiftPrepare and BrainshiftRegister are thin argument parsing over the functions the
/// `brainshift prepare` and `brainshift register` subcommands call.

#include "module_description.hpp"

#include <filesystem>

namespace brainshift::apps::slicer {

/// BrainshiftPrepare: labels, mra, optional mri → the model folder (`model`, a directory).
ModuleDescription prepare_module();

/// BrainshiftRegister: model folder, doppler, optional bmode and preopMRI → warpedMRI,
/// preopToIntraop, intraopToPreop (.nrrd displacement fields), reportFile, optional
/// resultDirectory (everything `brainshift register` writes).
ModuleDescription register_module();

/// A folder Slicer's directory button may point at, to be replaced whole by a new one: it must be
/// new, empty, or an earlier output of the same kind (holding `marker`, e.g. model.json for a
/// model, report.json for a result). \throws brainshift::Error naming the folder otherwise, so
/// that a folder of other files is never replaced.
void verify_replaceable_folder(const std::filesystem::path& dir, const char* marker);

}  // namespace brainshift::apps::slicer
