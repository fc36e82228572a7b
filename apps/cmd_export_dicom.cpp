#include "cmd_export_dicom.hpp"

#include "apps/workflow/model_folder.hpp"
#include "core/error.hpp"
#include "imaging/io/dicom_io.hpp"
#include "imaging/io/image_io.hpp"
#include "imaging/io/output_guard.hpp"

#include <CLI/CLI.hpp>

#include <ostream>

namespace brainshift::apps {

CLI::App* add_export_dicom_command(CLI::App& app, ExportDicomArgs& args) {
  CLI::App* cmd = app.add_subcommand(
      "export-dicom",
      "Write a volume (e.g. RES/warped_mri.nii.gz) as a DICOM MR series for a navigation "
      "system: new series, marked brain-shift corrected and not for diagnosis");
  cmd->add_option("--volume", args.volume,
                  "the volume to export (NIfTI, NRRD, MetaImage, VTI or a DICOM series), one "
                  "component, world RAS")
      ->required();
  cmd->add_option("--like", args.like,
                  "the original DICOM series (its folder or one file): its patient, study and "
                  "frame of reference are kept");
  cmd->add_option("--out", args.out, "the folder to write (IMG0001.dcm ...), replaced whole")
      ->required();
  cmd->add_option("--description", args.description,
                  std::string("Series Description (<= 64 characters; default \"") +
                      imaging::corrected_series_description + "\")");
  return cmd;
}

int run_export_dicom(const ExportDicomArgs& args, std::ostream& out) {
  workflow::verify_output_folder(args.out);
  const imaging::OutputLock lock(args.out);  // one run writes DIR at a time
  const std::string description =
      args.description.empty() ? imaging::corrected_series_description : args.description;
  BS_VERIFY(
      description.size() <= 64,
      "--description: a DICOM Series Description holds 64 characters, got " << description.size());
  imaging::DicomSeriesInfo source;
  if (args.like) {
    BS_VERIFY(imaging::is_dicom_path(*args.like),
              args.like->string() << ": --like takes a DICOM series (a folder or a .dcm file)");
    (void)imaging::read_dicom_series(*args.like, &source);
  }
  const imaging::VolumeF volume = imaging::read_volume(args.volume);
  BS_VERIFY(volume.components == 1, args.volume.string()
                                        << ": a DICOM MR series holds one component per voxel, got "
                                        << volume.components);
  workflow::write_folder_atomically(args.out, [&](const std::filesystem::path& dir) {
    imaging::write_dicom_series(dir, volume, source, description);
  });
  out << "wrote " << args.out.string() << ": " << volume.geometry.size[2] << " MR slices of "
      << volume.geometry.size[0] << " x " << volume.geometry.size[1] << " (" << description << ")"
      << (args.like ? ", patient and study of " + args.like->string() : std::string()) << '\n';
  return 0;
}

}  // namespace brainshift::apps
