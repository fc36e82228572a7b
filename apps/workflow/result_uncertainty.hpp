#pragma once
/// @file
/// @brief The predicted-error outputs of `register` (constraints/registration/
/// uncertainty.hpp): RES/uncertainty.nii.gz and report.json → `uncertainty`.
///
/// The map is on the grid of displacement.nii.gz (the pre-operative grid, rest frame): at each
/// voxel centre inside the mesh, sqrt of the barycentrically interpolated nodal tr Σ (mm), the
/// RMS length of the predicted 3-D error of the displacement there; 0 outside the brain (and
/// the rigid term alone in the fixed region, whose deformation is prescribed but which moves with
/// the uncertain pose).

#include "apps/workflow/session.hpp"
#include "constraints/registration/uncertainty/uncertainty.hpp"
#include "imaging/io/volume.hpp"

#include <nlohmann/json.hpp>

#include <vector>

namespace brainshift::workflow {

/// The tetrahedra of the tumour: those whose Young's modulus is the manifest's tumour modulus
/// (model.json → materials.tumour; in kPa or Pa), none when it equals the brain's or is absent.
std::vector<index_t> tumour_tets(const Session& s);

struct ResultUncertainty {
  bool computed = false;  ///< false: skipped (replay --uncertainty); nothing below is set
  constraints::UncertaintyResult nodal;
  imaging::VolumeF map;    ///< predicted error (mm), one component, pre-operative grid
  double median_mm = 0.0;  ///< over the voxels inside the mesh
  double p95_mm = 0.0;
  double seconds_map = 0.0;  ///< rasterising the map
};

/// Predicted error of a result: nodal values (with the scene's options) and the voxel map.
/// \throws brainshift::Error when the result does not fit the model.
ResultUncertainty compute_result_uncertainty(const Session& s,
                                             const constraints::RegistrationResult& r);

/// report.json → `uncertainty`: at_tumour_mm (at the centroid of the tumour's tetrahedra, null
/// without a tumour material), at_landmarks (when `data` has landmarks: model points' predicted
/// error, mm), median_mm, p95_mm, estimation, seconds and the estimated parameters (s² and its
/// candidate estimates, the held-out blocks, the rigid term's rank) and `tracking_prior` (the
/// scene's stated tracking accuracy: translation_mm, rotation_deg, centre_mm of the rotation).
nlohmann::json uncertainty_report(const Session& s, const ResultUncertainty& u,
                                  const constraints::IntraopData& data);

}  // namespace brainshift::workflow
