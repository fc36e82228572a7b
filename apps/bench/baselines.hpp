#pragma once
/// @file
/// @brief The baselines the benchmark compares the constraint-based registration with, on the same
/// model and data: the rigid start alone, and the seeds' prescribed-displacement forward model.
/// Positions in mm, model (pre-operative) frame; the rigid part maps intra-operative points into
/// it (RegistrationResult::rigid), as for register_model().

#include "constraints/registration/registration.hpp"

namespace brainshift::workflow {

/// The rigid start alone: no deformation.
constraints::RegistrationResult rigid_only(constraints::RegistrationModel& model,
                                           const constraints::IntraopData& data,
                                           const constraints::RegistrationOptions& options);

/// The seeds' approach (prescribed displacements, a forward model): after the same rigid start,
/// each vessel point is assigned once to its nearest pre-operative skeleton point (within the
/// pairing distance); each skeleton point so chosen is displaced onto the mean of its points by
/// point-to-point rows (as soft as our vessel rows), and the corotational model is solved with
/// these displacements. No sliding along the vessels and no re-pairing.
constraints::RegistrationResult prescribed_displacement(
    constraints::RegistrationModel& model, const constraints::IntraopData& data,
    const constraints::RegistrationOptions& options);

}  // namespace brainshift::workflow
