#pragma once
/// @file
/// @brief The registration's start as callers see it: the pose of a pre-dura sweep (stored and
/// passed to every later registration as IntraopData::pose) and the rigid-only start (the
/// benchmark's "rigid only" baseline). register_model() runs the full start itself
/// (run_start.hpp). Positions in mm, world (RAS) frame; poses map tracked points into the model.

#include "constraints/registration/registration_types.hpp"

namespace brainshift::constraints {

/// The navigation offset from a sweep made on the dura before it is opened (no shift yet): the
/// global start's rigid pose (no bulk response) of its vessel points (#N×3, tracked frame, mm).
/// `accepted` false (with the reason in `message`) when the sweep cannot give one; the transform
/// is then the identity.
StartResult pre_dura_pose(const RegistrationModel& model, ConstRef<MatrixX3d> vessel_points,
                          const RegistrationOptions& options);

/// The start's rigid part alone (options.start is ignored): the global start without the bulk
/// response (the identity, with the reason in stop_reason, when not accepted). The "rigid only"
/// baseline of the benchmark.
StartResult rigid_start(const RegistrationModel& model, const IntraopData& data,
                        const RegistrationOptions& options);

}  // namespace brainshift::constraints
