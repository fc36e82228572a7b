#pragma once
/// @file
/// @brief NRRD volumes (.nrrd, attached data) read and written here rather than through VTK:
/// vtkNrrdReader (VTK 9.1) ignores `space directions`, so oblique or LPS files would come out in
/// the wrong place, and VTK has no NRRD writer. http://teem.sourceforge.net/nrrd/format.html
///
/// Reading: `space` right-anterior-superior, left-posterior-superior or left-anterior-superior
/// (or their short forms RAS, LPS, LAS); without `space`, the grid is taken as RAS with the
/// `spacings` field (a warning is logged). 3-D scalar volumes or 4-D volumes whose first axis is
/// the component axis (`space directions` "none"). Types int8 to float64; encodings raw and
/// gzip; either endianness. Three-component volumes are vectors in the file's space and are
/// converted with the geometry; their `measurement frame`, when given, is honoured (each vector
/// is taken to the file's space by it before the conversion). Key/value pairs (`key:=value`) are
/// read and ignored. Detached data (.nhdr), `byte skip` and `line skip` are refused.

#include "imaging/io/volume.hpp"

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

namespace brainshift::imaging {

/// The anatomical frame a NRRD file is written in.
enum class NrrdSpace { RAS, LPS };

/// Reads a .nrrd volume into world RAS (mm); 3-component volumes (vectors) are converted too.
/// \throws brainshift::Error, one line naming the file: missing file, not a NRRD, an unsupported
/// field value (named), truncated or corrupt data, a bad geometry (see verify_geometry()).
VolumeF read_nrrd(const std::filesystem::path& path);

/// Writes `volume` (world RAS) to `path` directly (no temporary; see write_atomically()) as
/// raw little-endian float32, in `space`: for LPS, the geometry and the x, y components of a
/// 3-component volume are negated. 3-component volumes get axis kind `vector` and an identity
/// `measurement frame` (their components are in `space`), others `list`. `key_values` are
/// written as NRRD key/value pairs (`key:=value`; keys without ":=" or newlines).
/// \throws brainshift::Error naming the path when it cannot be written.
void write_nrrd(const std::filesystem::path& path, const VolumeF& volume, NrrdSpace space,
                const std::vector<std::pair<std::string, std::string>>& key_values = {});

/// As above for labels: raw uint8 (no vector conversion).
void write_nrrd(const std::filesystem::path& path, const LabelVolume& volume, NrrdSpace space);

}  // namespace brainshift::imaging
