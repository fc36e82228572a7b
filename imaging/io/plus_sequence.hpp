#pragma once
/// @file
/// @brief PLUS sequence files (.seq.mha, .seq.nrrd): tracked 2-D ultrasound frames as PLUS,
/// 3D Slicer (Sequences) and IBIS record them.
/// http://perk-software.cs.queensu.ca/plus/doc/nightly/user/FileSequenceFile.html
///
/// A MetaImage header (`Key = Value` lines, `ElementDataFile = LOCAL` last) whose DimSize is
/// columns, rows, frames, followed by the frames' pixels (raw, or zlib when `CompressedData =
/// True`). Each frame n carries fields `Seq_FrameNNNN_<Name>` — among them
/// `<From>To<To>Transform` (16 numbers, a row-major 4×4 matrix, mm), `<From>To<To>TransformStatus`
/// (OK or INVALID), `Timestamp` and `ImageStatus`. `UltrasoundImageOrientation` (two letters: the
/// image x axis towards the Marked or Unmarked side of the transducer, y Far from or Near it)
/// says how the pixels are stored; as PLUS does, frames are turned to MF on reading, the
/// orientation PLUS's transforms (Image to Probe calibration) refer to. The Image coordinate frame
/// is the pixel grid: pixel (column i, row j) of the MF frame is the point (i, j, 0).
///
/// The reference frame of the transforms (Reference, Tracker, …) is taken as world RAS mm, as
/// 3D Slicer does when it shows a PLUS stream.

#include "core/config.hpp"

#include <Eigen/Geometry>

#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace brainshift::imaging {

/// One tracked frame's transforms, by name (e.g. "ProbeToTracker"), and its status.
struct SequenceFrame {
  std::map<std::string, Eigen::Matrix4d> transforms;  ///< the transforms whose status is OK
  std::vector<std::string> invalid;                   ///< transforms given with a bad status
  double timestamp = 0.0;                             ///< s (0 when absent)
  bool image_ok = true;                               ///< ImageStatus OK (or absent)
};

/// A sequence as read: frames turned to MF, one float per pixel.
struct PlusSequence {
  int columns = 0, rows = 0;
  std::string orientation_in_file = "MF";
  std::vector<SequenceFrame> frames;
  std::vector<float> pixels;  ///< frame-major, then row, then column (MF orientation)
  float at(std::size_t frame, int column, int row) const {
    return pixels[(frame * std::size_t(rows) + std::size_t(row)) * std::size_t(columns) +
                  std::size_t(column)];
  }
};

/// True when `path` ends in .seq.mha or .seq.nrrd (any case).
bool is_plus_sequence(const std::filesystem::path& path);

/// Reads a .seq.mha or .seq.nrrd file. The NRRD form (PLUS's vtkPlusNrrdSequenceIO) has the
/// NRRD fields (type, sizes with kinds "domain domain [domain] list", encoding raw or gzip) and
/// the orientation (`ultrasound image orientation`) and frame fields as key/value pairs.
/// The pixel data the header claims is checked against the file before it is allocated.
/// \throws brainshift::Error, one line naming the file: not a MetaImage, a field missing or
/// malformed (named, with the frame), an unsupported element type, channel count, orientation
/// or dimension, truncated or corrupt pixel data.
PlusSequence read_plus_sequence(const std::filesystem::path& path);

/// The Image-to-world transform of each frame, or nothing for a frame that cannot be placed (its
/// transform missing or invalid, or its image status not OK). The transform is, in this order of
/// preference: `image_to` (a name such as "ImageToReference") when given; else with
/// `calibration` (Image to Probe), the frame's ProbeToReference or ProbeToTracker times it; else
/// ImageToReference, ImageToTracker, or the frame's own ImageToProbe after ProbeToReference or
/// ProbeToTracker. \throws brainshift::Error naming `file` when no frame has
/// such a transform (listing the names the file has).
std::vector<std::optional<Eigen::Matrix4d>> image_to_world(
    const PlusSequence& sequence, const std::string& file,
    const std::optional<Eigen::Matrix4d>& calibration, const std::string& image_to = "");

/// A 4×4 matrix from a text file of 16 numbers, row-major (spaces, commas, tabs or new lines
/// between them), as PLUS's device-set configuration writes a `Matrix` attribute; the last row
/// must be 0 0 0 1. \throws brainshift::Error naming the file.
Eigen::Matrix4d read_matrix_file(const std::filesystem::path& path);

}  // namespace brainshift::imaging
