#pragma once
/// @file
/// @brief The one conversion of a registration result into the intra-operative frame (README
/// "Frames"): the model is the pre-operative frame and the rigid start T maps intra-operative
/// points into it (RegistrationResult::rigid.transform, model_from_intraop), so a model point at
/// x (model frame, after the deformation) is at T⁻¹ x in the intra-operative frame. Used by the
/// result fields (result_fields.hpp) and the benchmark's TRE (bench_run.hpp). mm, world RAS.

#include "constraints/registration/registration.hpp"
#include "core/config.hpp"

namespace brainshift::workflow {

/// T⁻¹: model (pre-operative) frame → intra-operative frame.
Eigen::Isometry3d intraop_from_model(const constraints::RegistrationResult& r);

/// `points` (#P×3, model frame, mm; e.g. r.positions or points interpolated from them) in the
/// intra-operative frame: each row mapped by intraop_from_model(r).
MatrixX3d to_intraop_frame(const constraints::RegistrationResult& r, ConstRef<MatrixX3d> points);

}  // namespace brainshift::workflow
