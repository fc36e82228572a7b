#pragma once
/// @file
/// @brief The registration's start (internal to register_model() and start_only()): the pose
/// (a warm start's, a given one, or the global start's) and the bulk shift, the start's state,
/// and the bulk shift as a load. Positions in mm, model frame (world RAS of the pre-operative
/// model) unless said otherwise.

#include "constraints/registration/loop/registration_stage.hpp"
#include "constraints/registration/registration_types.hpp"
#include "constraints/registration/start/start.hpp"

#include <memory>
#include <vector>

namespace brainshift::constraints::detail {

/// The start: the pose — a warm start's (`initial`), the given one (IntraopData::pose) or the
/// global start's (options.start RIGID) — and the bulk shift. Writes res.start,
/// res.seconds.rigid and the per-point basis of the bulk shift.
void run_start(const RegistrationModel& model, const IntraopData& data,
               const RegistrationOptions& options, const RegistrationResult* initial, bool vessels,
               RegistrationResult& res, std::vector<Matrix3d>& shift_basis);

/// The load amplitude a (per axis, in units of the 1 g loads of RegistrationModel::load_response)
/// whose response moves the vessel points (in.vessel_points, model frame) by the start's bulk
/// shift on average. Zero when no bulk shift was accepted, without the load basis, or singular.
Vector3d bulk_amplitude(const RegistrationModel& model, const LoopInputs& in,
                        const RegistrationResult& res, const RegistrationOptions& options);

/// The start's state (#N×3): the rest nodes plus the bulk response to the accepted bulk shift
/// (a translation without the load basis); a warm start's own positions.
MatrixX3d start_positions(const RegistrationModel& model, const LoopInputs& in,
                          const RegistrationResult& res, const RegistrationOptions& options,
                          const RegistrationResult* initial);

/// The body acceleration (mm/s²) of amplitude `a` (bulk_amplitude()) at the scene's density.
Vector3d bulk_gravity(const Vector3d& amplitude, const RegistrationOptions& options);

/// The rigid-only start (pre_dura_pose(): no bulk response) as res.start.
void rigid_only_start(const RegistrationModel& model, const IntraopData& data,
                      const RegistrationOptions& options, RegistrationResult& res);

/// The elastic rest of the bulk load `gravity` (bulk_gravity()'s units): the rest nodes plus its
/// linear response (the load responses scaled back to amplitudes). Null when there is no load.
/// Where the whole response flattens or inverts an element (core::RestShape::degenerate > 0: a
/// linear response is not a large deformation's shape, and on a finer mesh its steepest
/// gradients do so first), the rest is the largest share of the load under which none does
/// (bisected to 1/4096), and `share` (when given) says which; the vessel rows carry the
/// remainder. Where even 1/4096 of it degenerates, the whole load's rest with its degenerate
/// elements at the mesh's rest (share 1).
std::shared_ptr<const core::RestShape> bulk_rest(const RegistrationModel& model,
                                                 const Vector3d& gravity,
                                                 const RegistrationOptions& options,
                                                 double* share = nullptr);

}  // namespace brainshift::constraints::detail
