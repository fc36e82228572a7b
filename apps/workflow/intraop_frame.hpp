#pragma once
/// @file
/// @brief The one conversion of a registration result into the intra-operative frame (README
/// "Frames"): the model is the pre-operative frame and the rigid start T maps intra-operative
/// points into it (RegistrationResult::rigid.transform, model_from_intraop), so a model point at
/// x (model frame, after the deformation) is at T⁻¹ x in the intra-operative frame. Used by the
/// result fields (result_fields.hpp) and the benchmark's TRE (bench_run.hpp). mm, world RAS.

#include "constraints/registration/registration.hpp"
#include "constraints/registration/registration_model.hpp"
#include "core/config.hpp"

#include <string>

namespace brainshift::workflow {

/// T⁻¹: model (pre-operative) frame → intra-operative frame.
Eigen::Isometry3d intraop_from_model(const constraints::RegistrationResult& r);

/// `points` (#P×3, model frame, mm; e.g. r.positions or points interpolated from them) in the
/// intra-operative frame: each row mapped by intraop_from_model(r).
MatrixX3d to_intraop_frame(const constraints::RegistrationResult& r, ConstRef<MatrixX3d> points);

/// How far the answer's rigid part moves the model's fixed base (its Dirichlet nodes, which the
/// deformation never moves: there φ(X) − X = T⁻¹X − X), mm. The base of the brain does not move in
/// surgery, so this is the share of the answer that no sag explains: from one sweep the pose can
/// take the sag and tilt the whole head (README "Frames"; issue 32). Zero without fixed nodes.
struct FixedBaseMotion {
  double mean_mm = 0.0;
  double max_mm = 0.0;
  index_t nodes = 0;  ///< fixed nodes measured
};
FixedBaseMotion fixed_base_motion(const constraints::RegistrationResult& r,
                                  const constraints::RegistrationModel& model);

/// The navigation accuracy (RMS, mm) a searched pose is held against: the scene's
/// global_start.navigation_accuracy_mm, or without one RESECT's measured 6.6 mm
/// (constraints::kResectNavigationAccuracyMm).
double navigation_yardstick_mm(const constraints::RegistrationOptions& options);

/// One line when a pose searched from one sweep (no pre-dura pose given) moves the fixed base
/// further on average than the navigation's accuracy: then the pose has likely taken the sag and
/// tilted the whole brain; empty otherwise (and always with a given pose).
std::string fixed_base_note(const FixedBaseMotion& m, bool pose_given, double yardstick_mm);

}  // namespace brainshift::workflow
