#include "data_synth/cases/case_catalog.hpp"

#include "core/error.hpp"

#include <sstream>

namespace brainshift::data_synth {

std::vector<std::string> case_names() {
  return {"standard",      "large_shift",       "deep_tumour_one_side_vessels",
          "noisy_doppler", "tracking_error",    "sparse_vessels",
          "resection",     "thin_structures",   "offset_12mm",
          "offset_20mm",   "sparse_offset_12mm"};
}

CaseParameters named_case(const std::string& name, std::uint32_t seed) {
  CaseParameters p;
  p.name = name;
  p.seed = seed;
  p.mesh.cell_size = 5.5;
  p.tled.error_tolerance = 0.02;  // mm: well below the 1 mm accuracy the registration targets
  p.vessels.seed = seed;
  p.vessels.root_spread = 30.0;  // mm: the trees cross the probe's field of view
  p.mri.seed = seed * 7919U + 1U;
  p.mra.seed = seed * 7919U + 2U;
  p.doppler.seed = seed * 7919U + 3U;
  p.bmode.seed = seed * 7919U + 4U;
  if (name == "standard" || name == "thin_structures") {
    p.thin_structures = name == "thin_structures";
  } else if (name == "large_shift") {
    p.mesh.brain_youngs_modulus = 0.6;  // kPa: 40 % of the default
    p.load.drain_depth = 200.0;         // fully drained
    p.load.gravity_direction = {-0.3, 0.0, -1.0};
  } else if (name == "deep_tumour_one_side_vessels") {
    p.geometry.tumour_offset = {18.0, 8.0, 8.0};
    p.geometry.tumour_radius = 10.0;
    p.vessels.one_side = true;
    p.vessels.deep_branches = 1;
  } else if (name == "noisy_doppler") {
    p.doppler.dropout = 0.4;
    p.doppler.speckle_shape = 1.5;
    p.doppler.spurious_blobs = 25;
    p.doppler.clutter_sigma = 12.0;
    p.doppler.blur_sigma = 1.0;
  } else if (name == "tracking_error") {
    p.tracking.translation = Vector3d(2.0, -1.5, 1.5);   // |t| ≈ 2.9 mm
    p.tracking.rotation_deg = Vector3d(2.0, -1.5, 1.5);  // ≈ 2.9°
    p.tracking_spec_translation_mm = 3.0;                // the declared "3 mm and 3°" (RMS)
    p.tracking_spec_rotation_deg = 3.0;
  } else if (name == "offset_12mm" || name == "offset_20mm") {
    // The standard sag seen through a large rigid tracking offset (RESECT: 1–20 mm, mostly
    // rigid), in the direction of tracking_error's: 12 mm / 3° or 20 mm / 4°.
    const bool big = name == "offset_20mm";
    const Vector3d dir = Vector3d(2.0, -1.5, 1.5).normalized();
    p.tracking.translation = (big ? 20.0 : 12.0) * dir;  // mm
    p.tracking.rotation_deg =
        (big ? 4.0 : 3.0) * dir;    // degrees (Z·Y·X angles ≈ a rotation vector)
    p.truth_in_image_frame = true;  // an offset to recover, truth where the images put it (RESECT)
  } else if (name == "sparse_vessels" || name == "sparse_offset_12mm") {
    // One small tree in view; sparse_offset_12mm sees it through offset_12mm's tracking offset:
    // few branches to pin a pose, and a large offset to find (the case a start could be
    // confidently wrong on).
    if (name == "sparse_offset_12mm") {
      const Vector3d dir = Vector3d(2.0, -1.5, 1.5).normalized();
      p.tracking.translation = 12.0 * dir;
      p.tracking.rotation_deg = 3.0 * dir;
      p.truth_in_image_frame = true;
    }
    p.vessels.cortical_trees = 1;
    p.vessels.min_generations = 3;
    p.vessels.max_generations = 3;
    p.vessels.deep_branches = 0;
    p.vessels.root_radius_min = 1.5;
    p.vessels.root_radius_max = 2.0;
  } else if (name == "resection") {
    p.resection = true;
  } else {
    std::ostringstream valid;
    for (const std::string& n : case_names()) valid << (valid.tellp() > 0 ? ", " : "") << n;
    BS_THROW("unknown phantom case '" << name << "' (valid: " << valid.str() << ")");
  }
  return p;
}

}  // namespace brainshift::data_synth
