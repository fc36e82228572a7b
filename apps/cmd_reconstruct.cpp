#include "cmd_reconstruct.hpp"

#include "core/error.hpp"
#include "core/timing.hpp"
#include "imaging/io/atomic_write.hpp"
#include "imaging/io/image_io.hpp"
#include "imaging/io/plus_sequence.hpp"
#include "imaging/reconstruction/volume_reconstruction.hpp"

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <fstream>
#include <ostream>

namespace brainshift::apps {
namespace {

void verify_parent(const std::filesystem::path& file) {
  const std::filesystem::path parent =
      file.parent_path().empty() ? std::filesystem::path(".") : file.parent_path();
  std::error_code ec;
  BS_VERIFY(std::filesystem::is_directory(parent, ec),
            file.string() << ": the folder " << parent.string() << " does not exist");
}

}  // namespace

CLI::App* add_reconstruct_command(CLI::App& app, ReconstructArgs& args) {
  CLI::App* cmd = app.add_subcommand(
      "reconstruct",
      "Reconstruct a volume from a PLUS sequence file of tracked ultrasound frames "
      "(.seq.mha, .seq.nrrd): pixel nearest neighbour, then hole filling between data");
  cmd->add_option("--sequence", args.sequence, "the PLUS sequence file (.seq.mha or .seq.nrrd)")
      ->required();
  cmd->add_option("--calibration", args.calibration,
                  "Image-to-Probe matrix: a text file of 16 numbers, row-major (PLUS's Matrix); "
                  "the frames are then placed by ProbeToReference (or ProbeToTracker) times it");
  cmd->add_option("--transform", args.transform,
                  "the frames' Image-to-world transform by name (e.g. ImageToReference); "
                  "default: ImageToReference, else ImageToTracker");
  cmd->add_option("--spacing", args.spacing_mm,
                  "output voxel size, mm (default: the frames' median pixel size)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--out", args.out, "the volume (NIfTI, NRRD, MetaImage or VTI), world RAS")
      ->required();
  cmd->add_option("--coverage", args.coverage,
                  "label volume: 1 reached by pixels, 2 filled between them, 0 outside");
  cmd->add_option("--report", args.report, "JSON report (frames, voxels, spacing)");
  return cmd;
}

int run_reconstruct(const ReconstructArgs& args, std::ostream& out) {
  const core::Stopwatch watch;
  BS_VERIFY(imaging::is_plus_sequence(args.sequence),
            args.sequence.string() << ": not a PLUS sequence file (.seq.mha or .seq.nrrd)");
  (void)imaging::image_format(args.out);  // a known extension, before the work
  verify_parent(args.out);
  if (args.coverage) {
    (void)imaging::image_format(*args.coverage);
    verify_parent(*args.coverage);
  }
  if (args.report) verify_parent(*args.report);
  imaging::SequenceReconstructionOptions o;
  if (args.calibration) o.calibration = imaging::read_matrix_file(*args.calibration);
  o.transform = args.transform;
  o.spacing_mm = args.spacing_mm;
  imaging::ReconstructionReport rep;
  imaging::LabelVolume coverage;
  const imaging::VolumeF v = imaging::reconstruct_sequence_file(
      args.sequence, o, &rep, args.coverage ? &coverage : nullptr);
  imaging::write_volume(args.out, v);
  if (args.coverage) {
    // Written as 8-bit labels: 0, 1, 2 are valid Label values.
    imaging::write_labels(*args.coverage, coverage);
  }
  const double seconds = watch.seconds();
  if (args.report) {
    const nlohmann::json j = {
        {"sequence", args.sequence.string()},
        {"volume", args.out.string()},
        {"frames", rep.frames},
        {"frames_placed", rep.frames_placed},
        {"frames_skipped", rep.frames_skipped},
        {"pixels_inserted", rep.pixels_inserted},
        {"spacing_mm", rep.spacing_mm},
        {"pixel_mm", rep.pixel_mm},
        {"size", {v.geometry.size[0], v.geometry.size[1], v.geometry.size[2]}},
        {"voxels", rep.voxels},
        {"voxels_hit", rep.voxels_hit},
        {"voxels_filled", rep.voxels_filled},
        {"voxels_empty", rep.voxels_empty},
        {"fill_radius_voxels", rep.fill_radius},
        {"seconds", seconds}};
    imaging::write_atomically(*args.report, [&](const std::filesystem::path& tmp) {
      std::ofstream f(tmp);
      f << j.dump(2) << '\n';
      f.close();
      BS_VERIFY(f.good(), args.report->string() << ": cannot write");
    });
  }
  out << "reconstructed " << args.out.string() << ": " << v.geometry.size[0] << " x "
      << v.geometry.size[1] << " x " << v.geometry.size[2] << " voxels of " << rep.spacing_mm
      << " mm from " << rep.frames_placed << " of " << rep.frames << " frames ("
      << rep.frames_skipped << " skipped: transform or image not OK); " << rep.voxels_hit
      << " voxels reached, " << rep.voxels_filled << " filled between them, in " << seconds
      << " s\n";
  return 0;
}

}  // namespace brainshift::apps
