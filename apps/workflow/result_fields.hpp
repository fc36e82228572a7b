#pragma once
/// @file
/// @brief The fields and images of a registration result, computed in memory, in the frames
/// users apply them in. Written by `brainshift register` (RES/) and by the Slicer module
/// BrainshiftRegister (at the paths Slicer gives).
///
/// Frames (README "Frames"): the model is the pre-operative frame; the rigid start T maps
/// intra-operative points into it (rigid.model_from_intraop). A pre-operative point X is now at
/// φ(X) = T⁻¹ (X + u(X)) in the intra-operative frame, with u the registration's nodal
/// displacement interpolated on the mesh; outside the brain φ is the rigid part T⁻¹ alone.
///
/// Two kinds of displacement field, both sampled exactly at voxel centres by rasterising the
/// mesh's tetrahedra (imaging/warping/warp_image.hpp), vectors and grids in world RAS here
/// (the Slicer files are converted to LPS when written):
/// - forward, on the pre-operative grid: d(X) = φ(X) − X (displacement.nii.gz; with the extension
///   below also intraop_to_preop.nrrd, which moves intra-operative content onto the MRI);
/// - resampling (ITK / Slicer sense, "transform from parent"), on the pre-operative grid moved by
///   the rigid part (oblique if it rotates), grown where needed to cover the deformed brain:
///   v(y) = φ⁻¹(y) − y, so
///   y + v(y) is the pre-operative point now at y (preop_to_intraop.nrrd: applied to pre-operative
///   content, it shows it where it is now).
/// The Slicer fields extend the brain's map trilinear_support_mm() beyond the mesh, so that
/// trilinear interpolation anywhere in the brain blends no rigid-part values across its surface.

#include "apps/workflow/result_uncertainty.hpp"
#include "apps/workflow/session.hpp"
#include "constraints/registration/registration.hpp"
#include "imaging/io/volume.hpp"

#include <functional>
#include <optional>

namespace brainshift::workflow {

/// Everything register writes apart from the report, overlay and mesh file.
struct ResultFields {
  Eigen::Isometry3d intraop_from_model;  ///< T⁻¹: model (pre-operative) → intra-operative frame
  MatrixX3d u_intra;                     ///< #N×3: φ(X_n) − X_n at the mesh nodes, mm
  imaging::VolumeF displacement;      ///< d = φ(X) − X on the pre-op grid (displacement.nii.gz)
  imaging::VolumeF intraop_to_preop;  ///< d on the pre-op grid, extended beyond the brain
  imaging::VolumeF preop_to_intraop;  ///< v = φ⁻¹(y) − y on the moved pre-op grid (above)
  std::optional<imaging::VolumeF> warped_mri;  ///< the MRI pulled through φ⁻¹ (with an MRI)
  ResultUncertainty uncertainty;  ///< predicted error (uncertainty.nii.gz; result_uncertainty.hpp)
};

/// Computes the fields of a result (and warps `mri` when given, on its own grid); the predicted
/// error only when `with_uncertainty` (else ResultUncertainty::computed is false).
/// \throws brainshift::Error when the result's positions do not fit the model.
ResultFields compute_result_fields(const Session& s, const constraints::RegistrationResult& r,
                                   const imaging::VolumeF* mri, bool with_uncertainty = true);

/// The parts of ResultFields, in the order a serial computation makes them.
enum class ResultPart {
  FORWARD,      ///< displacement and intraop_to_preop (one rasterisation)
  INVERSE,      ///< preop_to_intraop
  WARPED_MRI,   ///< warped_mri (only with an MRI)
  UNCERTAINTY,  ///< uncertainty (only when asked for)
};
/// Called with each part as soon as it is computed, on the thread that computed it.
using ResultPartReady = std::function<void(ResultPart)>;

/// As compute_result_fields(), into `f`, handing each part to `ready` as soon as it is there (to
/// write its file while the rest is computed). With `threads` ≥ 2 the forward fields are computed
/// on the calling thread and the inverse field, the warped MRI and the predicted error, in that
/// order, on a second thread, so `ready` runs on both threads at once; it may read only the part
/// it is given (and intraop_from_model, u_intra) until this returns. With `threads` = 1 all parts
/// come in the order of ResultPart on the calling thread. The fields do not depend on `threads`
/// (each kernel's result is independent of its thread count). An exception from either thread
/// (a kernel's or `ready`'s) is rethrown here once both have stopped.
void compute_result_fields(const Session& s, const constraints::RegistrationResult& r,
                           const imaging::VolumeF* mri, bool with_uncertainty, int threads,
                           ResultFields& f, const ResultPartReady& ready);

}  // namespace brainshift::workflow
