#pragma once
/// @file
/// @brief `brainshift export-dicom`: a volume (the warped MRI, typically) as a DICOM MR series,
/// the route a navigation system's planning software imports:
///
///   brainshift export-dicom --volume RES/warped_mri.nii.gz [--like MRI_SERIES] --out DIR
///                           [--description TEXT]
///
/// DIR is written whole or not at all (one file per slice, IMG0001.dcm …; an existing DIR is
/// replaced only once the new one is complete). With --like (a folder holding the original
/// DICOM series, or one file of it), the new series keeps its patient, study and frame of
/// reference; it always gets new series and instance UIDs, the Series Description "Brain-shift
/// corrected (brainshift) - NOT FOR DIAGNOSIS" unless --description is given, and Image Type
/// DERIVED\SECONDARY. Geometry: world RAS volume → DICOM's LPS patient frame (dicom_io.hpp).

#include <filesystem>
#include <iosfwd>
#include <optional>
#include <string>

namespace CLI {
class App;
}  // namespace CLI

namespace brainshift::apps {

/// Arguments of `brainshift export-dicom`.
struct ExportDicomArgs {
  std::filesystem::path volume;               ///< any volume brainshift reads, one component
  std::optional<std::filesystem::path> like;  ///< the original DICOM series (folder or a file)
  std::filesystem::path out;                  ///< the series folder to write
  std::string description;                    ///< Series Description; empty: the default
};

/// Registers `export-dicom` on `app`. `args` is not owned and must outlive `app`.
CLI::App* add_export_dicom_command(CLI::App& app, ExportDicomArgs& args);

/// Writes the series; one summary line on `out`.
/// @return 0 on success.
/// \throws brainshift::Error, one line naming the file: unreadable volume or series, more than
/// one component, an output folder whose parent does not exist.
int run_export_dicom(const ExportDicomArgs& args, std::ostream& out);

}  // namespace brainshift::apps
