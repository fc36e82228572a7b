#pragma once
/// @file
/// @brief A named case's recipe on the brain of a label volume (`brainshift phantom --labels`):
/// the same truth (TLED neo-Hookean sag on its own voxel mesh, skull contact on the brain's
/// closed hull grown by the CSF gap), vessels over the cortex under the craniotomy, images,
/// landmarks and folder layout as phantom_case.hpp; case.json's parameters.geometry states the
/// labels file, the hull, and where the craniotomy and the tumour came from (given, from the
/// labels, or default) — see label_anatomy.hpp.

#include "data_synth/cases/case_anatomy.hpp"
#include "data_synth/cases/phantom_case.hpp"
#include "data_synth/geometry/label_anatomy.hpp"

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>

namespace brainshift::data_synth {

struct LabelCaseRequest {
  std::filesystem::path labels;        ///< label volume (0/1/2/3), world RAS
  std::string case_name = "standard";  ///< the recipe: one of case_names()
  std::uint32_t seed = 1;
  std::optional<Vector3d> craniotomy;  ///< near the brain surface, mm (default: label_anatomy.hpp)
  std::optional<Vector3d> tumour_centre;  ///< inside the brain, mm
  std::optional<double> tumour_radius;    ///< mm
  /// Truth mesh cell, mm. prepare's clinical model has edges of ~10 mm; 5 mm keeps the truth
  /// mesh independent and finer (≈ 15k nodes on an adult brain).
  double cell_size = 5.0;
};

/// The case parameters of the recipe for this anatomy (vessels, images, probe, load, tracking of
/// the named case; the truth mesh's cell size from the request).
CaseParameters label_case_parameters(const LabelCaseRequest& request);

/// The anatomy of the request's labels, ready for generate_case(parameters, anatomy, options).
/// \throws brainshift::Error (one line naming the value) on unreadable labels, no brain, or a
/// tumour / craniotomy outside the brain.
CaseAnatomy label_case_anatomy(const LabelCaseRequest& request, const CaseParameters& parameters);

/// Checks the options, builds the anatomy, and writes the case (atomically, as generate_case).
CaseSummary generate_label_case(const LabelCaseRequest& request, const CaseOptions& options);

}  // namespace brainshift::data_synth
