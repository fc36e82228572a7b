#pragma once
/// @file
/// @brief `brainshift reconstruct`: a PLUS sequence file (tracked 2-D ultrasound frames, .seq.mha
/// or .seq.nrrd)
/// as a volume, as PLUS's VolumeReconstructor makes it (imaging/reconstruction/):
///
///   brainshift reconstruct --sequence S.seq.mha [--calibration ImageToProbe.txt]
///                          [--transform ImageToReference] [--spacing MM] --out V.nii.gz
///                          [--coverage C.nii.gz] [--report R.json]
///
/// The frames are placed by their ImageToReference (or ImageToTracker) transform, or with
/// --calibration (16 numbers, row-major, Image to Probe) by ProbeToReference (or ProbeToTracker)
/// times it, or by the transform --transform names; frames whose transform or image status is
/// not OK are skipped and counted. The volume is in world RAS mm (the sequence's reference frame,
/// as 3D Slicer shows a PLUS stream); --coverage marks voxels reached by pixels (1), filled
/// between them (2) and outside the sweep (0). `register --doppler` and `replay --sequence`
/// accept sequence files directly (reconstructed at the default spacing).

#include <filesystem>
#include <iosfwd>
#include <optional>
#include <string>

namespace CLI {
class App;
}  // namespace CLI

namespace brainshift::apps {

/// Arguments of `brainshift reconstruct`.
struct ReconstructArgs {
  std::filesystem::path sequence;                    ///< .seq.mha or .seq.nrrd
  std::optional<std::filesystem::path> calibration;  ///< Image-to-Probe matrix file
  std::string transform;                             ///< e.g. "ImageToReference"; empty: auto
  std::optional<double> spacing_mm;                  ///< default: the frames' pixel size
  std::filesystem::path out;                         ///< the volume
  std::optional<std::filesystem::path> coverage;     ///< label volume 0/1/2
  std::optional<std::filesystem::path> report;       ///< JSON
};

/// Registers `reconstruct` on `app`. `args` is not owned and must outlive `app`.
CLI::App* add_reconstruct_command(CLI::App& app, ReconstructArgs& args);

/// Reconstructs and writes the files (each atomically; the output folders are checked first);
/// one summary line on `out`. @return 0 on success.
/// \throws brainshift::Error, one line naming the file and the problem.
int run_reconstruct(const ReconstructArgs& args, std::ostream& out);

}  // namespace brainshift::apps
