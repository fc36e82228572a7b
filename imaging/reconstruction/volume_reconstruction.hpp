#pragma once
/// @file
/// @brief Volume reconstruction of tracked 2-D ultrasound frames (a PLUS sequence), as PLUS's
/// VolumeReconstructor does it: pixel nearest neighbour (each pixel centre adds its value to the
/// voxel it falls in; a voxel's value is the mean of its pixels), then hole filling.
///
/// The grid is axis-aligned in world RAS, `spacing_mm` isotropic, over the bounding box of the
/// placed frames' pixel centres. Hole filling closes gaps *between* data only: a voxel no pixel
/// reached takes, along each axis where it lies in a gap of at most `fill_radius` voxels between
/// two reached voxels, the linear interpolation between them, averaged over such axes. The
/// radius follows from the sweep itself — the largest distance between consecutive placed
/// frames' centres, in voxels, plus one — capped by `max_fill_radius`; the sweep's outside is
/// never extrapolated (those voxels stay 0 and are counted).

#include "imaging/io/plus_sequence.hpp"
#include "imaging/io/volume.hpp"

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace brainshift::imaging {

struct ReconstructionOptions {
  double spacing_mm = 0.5;    ///< output voxel size, mm (> 0)
  int max_fill_radius = 10;   ///< voxels; 0: no hole filling
  double max_voxels = 2.7e8;  ///< a larger grid is an error (1 GiB of float)
};

struct ReconstructionReport {
  int frames = 0;          ///< in the sequence
  int frames_placed = 0;   ///< inserted
  int frames_skipped = 0;  ///< transform missing or invalid, or image status not OK
  long long pixels_inserted = 0;
  long long voxels = 0;         ///< in the grid
  long long voxels_hit = 0;     ///< reached by a pixel
  long long voxels_filled = 0;  ///< filled between data
  long long voxels_empty = 0;   ///< outside the sweep (0)
  int fill_radius = 0;          ///< voxels, as derived (see above)
  double spacing_mm = 0.0;      ///< the output voxel size used
  double pixel_mm = 0.0;        ///< the frames' median pixel size (from their transforms)
};

/// Reconstructs `sequence` with each frame's Image-to-world transform (image_to_world(); a
/// frame without one is skipped). @param[out] coverage  when not null: on the output grid, 1
/// where pixels fell, 2 where filled between them, 0 outside the sweep. \throws brainshift::Error
/// naming `file`: no frame placed, a non-positive spacing, a grid over max_voxels (with the spacing
/// that would fit).
VolumeF reconstruct_volume(const PlusSequence& sequence,
                           const std::vector<std::optional<Eigen::Matrix4d>>& image_to_world,
                           const ReconstructionOptions& options, const std::string& file,
                           ReconstructionReport* report = nullptr,
                           Volume<std::uint8_t>* coverage = nullptr);

/// How to read and reconstruct a sequence file (reconstruct_sequence_file()).
struct SequenceReconstructionOptions {
  std::optional<Eigen::Matrix4d> calibration;  ///< Image to Probe (with ProbeTo* transforms)
  std::string transform;                       ///< the Image-to-world transform's name, if set
  std::optional<double> spacing_mm;            ///< default: see reconstruct_sequence_file()
  double max_default_voxels = 6.4e7;           ///< the default spacing's grid bound
};

/// Reads the PLUS sequence `path` and reconstructs it (read_plus_sequence(), image_to_world(),
/// reconstruct_volume()). Without a spacing, the frames' median pixel size (the norm of the
/// transform's pixel axes), coarsened if needed so that the grid holds at most
/// max_default_voxels. \throws brainshift::Error, one line naming the file.
VolumeF reconstruct_sequence_file(const std::filesystem::path& path,
                                  const SequenceReconstructionOptions& options,
                                  ReconstructionReport* report = nullptr,
                                  Volume<std::uint8_t>* coverage = nullptr);

}  // namespace brainshift::imaging
