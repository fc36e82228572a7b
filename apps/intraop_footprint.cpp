#include "intraop_footprint.hpp"

#include <algorithm>
#include <cmath>

#include "core/error.hpp"
#include "imaging/footprint/footprint.hpp"
#include "imaging/io/image_io.hpp"

namespace brainshift::apps {

IntraopFootprint footprint_from_bmode(const std::filesystem::path& bmode) {
  const imaging::VolumeF b = imaging::read_volume(bmode);
  BS_VERIFY(b.components == 1, bmode.string() << ": expected a scalar B-mode volume, got " << b.components
                                              << " components");
  const auto& g = b.geometry;
  imaging::ProbePose pose;
  pose.face_centre = g.index_to_world(Vector3d(0.5 * (g.size[0] - 1), 0.5 * (g.size[1] - 1), 0.0));
  pose.axis = g.direction.col(2);
  pose.lateral = Vector3d(g.direction.col(0));
  imaging::FootprintOptions options;
  // Rays over the probe face only: the central 30 mm (a typical face; the image is wider than
  // the face and shows the brain surface curving away beyond it, which is not a contact).
  options.aperture_width_mm = std::min(30.0, (g.size[0] - 1) * g.spacing[0]);
  options.aperture_elevation_mm = std::min(30.0, (g.size[1] - 1) * g.spacing[1]);
  const imaging::FootprintResult r = imaging::extract_footprint(b, pose, options);
  IntraopFootprint f;
  f.points = r.points;
  f.normals = r.normals;
  f.report = {{"file", bmode.string()},
              {"status", r.status == imaging::FootprintStatus::OK ? "ok" : "no_band"},
              {"message", r.message},
              {"points", r.points.rows()},
              {"threshold", std::isfinite(r.threshold) ? nlohmann::json(r.threshold) : nlohmann::json(nullptr)}};
  return f;
}

}  // namespace brainshift::apps
