#pragma once
/// @file
/// @brief The probe footprint from a tracked B-mode volume file, for `register --bmode`, `bench`
/// and `extract footprint`. The beam direction and the probe face come from the data
/// (imaging/footprint/beam_direction.hpp: the narrow end of the swept fan is the face; the grid's
/// axes do not matter, so freehand volumes on oblique grids work as our probe-aligned phantoms
/// do), or the direction is given (from the tracked probe: world RAS, into the tissue).

#include "core/config.hpp"
#include "imaging/io/volume.hpp"

#include <nlohmann/json.hpp>

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace brainshift::workflow {

struct IntraopFootprint {
  MatrixX3d points;    ///< #P×3 world RAS mm
  MatrixX3d normals;   ///< #P×3 unit, into the tissue
  bool found = false;  ///< a contact band was found (else no points; report.message says why)
  std::vector<std::string> warnings;  ///< doubts about a footprint that was found (small, deep, …)
  /// file, status ("ok" / "no_band"), message, points, probe_direction, direction_source
  /// ("given" / "estimated"), fan_fit, contrast, threshold, width_mm, elevation_mm,
  /// face_distance_mm (largest), warnings.
  nlohmann::json report;
};

/// \throws brainshift::Error naming the file when it cannot be read, is not scalar or has no
/// swept (non-zero) region. No band found is not an error here: no points, and the report says
/// why (`extract footprint` makes it one).
IntraopFootprint footprint_from_bmode(const std::filesystem::path& bmode,
                                      const std::optional<Vector3d>& direction = {});
/// The same from a volume in memory (e.g. received over OpenIGTLink); `name` stands for the file.
IntraopFootprint footprint_from_bmode(const imaging::VolumeF& bmode, const std::string& name,
                                      const std::optional<Vector3d>& direction = {});

}  // namespace brainshift::workflow
