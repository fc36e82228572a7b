#include "apps/workflow/intraop_footprint.hpp"

#include "core/error.hpp"
#include "imaging/footprint/freehand_footprint.hpp"
#include "imaging/io/image_io.hpp"

#include <algorithm>
#include <cmath>

namespace brainshift::workflow {
namespace {

nlohmann::json vector_json(const Vector3d& v) {
  return nlohmann::json::array({v.x(), v.y(), v.z()});
}

nlohmann::json number_or_null(double v) {
  return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr);
}

}  // namespace

IntraopFootprint footprint_from_bmode(const std::filesystem::path& bmode,
                                      const std::optional<Vector3d>& direction) {
  return footprint_from_bmode(imaging::read_volume(bmode), bmode.string(), direction);
}

IntraopFootprint footprint_from_bmode(const imaging::VolumeF& b, const std::string& bmode,
                                      const std::optional<Vector3d>& direction) {
  BS_VERIFY(b.components == 1,
            bmode << ": expected a scalar B-mode volume, got " << b.components << " components");
  imaging::FreehandFootprint r;
  try {
    r = imaging::extract_freehand_footprint(b, direction);
  } catch (const Error& e) {
    throw Error(bmode + ": " + e.what(), e.where());
  }
  IntraopFootprint f;
  f.found = r.footprint.status == imaging::FootprintStatus::OK;
  f.points = r.footprint.points;
  f.normals = r.footprint.normals;
  f.warnings = r.warnings;
  const double deepest = r.face_distance_mm.empty() ? 0.0
                                                    : *std::max_element(r.face_distance_mm.begin(),
                                                                        r.face_distance_mm.end());
  f.report = {{"file", bmode},
              {"status", f.found ? "ok" : "no_band"},
              {"message", r.footprint.message},
              {"points", r.footprint.points.rows()},
              {"probe_direction", vector_json(r.beam.direction)},
              {"direction_source", r.beam.given ? "given" : "estimated"},
              {"probe_lateral", vector_json(r.beam.lateral)},
              {"face_centre", vector_json(r.beam.face_centre)},
              {"fan_fit", r.beam.fan_fit},
              {"near_end_mm", {r.beam.near_width_mm, r.beam.near_elevation_mm}},
              {"contrast", r.footprint.contrast},
              {"threshold", number_or_null(r.footprint.threshold)},
              {"width_mm", r.width_mm},
              {"elevation_mm", r.elevation_mm},
              {"face_distance_mm", deepest},
              {"warnings", r.warnings}};
  return f;
}

}  // namespace brainshift::workflow
