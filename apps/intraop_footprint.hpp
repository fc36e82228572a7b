#pragma once
/// @file
/// @brief The probe footprint from a tracked B-mode volume file. Convention (what navigation
/// systems and our phantoms write): the volume's k axis is the beam direction, into the tissue,
/// and its first slice (k = 0) is at or above the probe face; i and j span the face. The probe
/// pose is therefore read from the image header: face centre = centre of slice k = 0, axis =
/// third direction column, lateral = first.

#include <filesystem>

#include <nlohmann/json.hpp>

#include "core/config.hpp"

namespace brainshift::apps {

struct IntraopFootprint {
  MatrixX3d points;   ///< #P×3 world RAS mm
  MatrixX3d normals;  ///< #P×3 unit, into the tissue
  nlohmann::json report;
};

/// \throws brainshift::Error naming the file when it cannot be read or is not scalar. No band
/// found is not an error: no points, and the report says why.
IntraopFootprint footprint_from_bmode(const std::filesystem::path& bmode);

}  // namespace brainshift::apps
