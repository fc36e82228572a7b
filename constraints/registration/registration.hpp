#pragma once
/// @file
/// @brief Constraint-based ICP registration (seed 002 §3.4, Algorithm 1). No file I/O here.
///
/// register_model() is Algorithm 1 run through a schedule of stages (registration_stage.hpp):
///   start  — the global start (global_start.hpp: rigid pose plus the model's bulk response, found
///            by an exhaustive search of the skeleton's distance map and refined by robust ICP), or
///            with IDENTITY the bulk-shift search alone (one block, run_start());
///   HELD   — when a bulk shift was accepted: pairs made at the points less the bulk motion, held
///            until the model has settled on them;
///   FREE   — nearest-feature pairing, frozen when it cycles, until settled;
///   SMOOTH — the vessel rows' compliance chosen by the noise model (noise_model.hpp: block
///            cross-validation over the skeleton's branches) from the converged FREE stage, then
///            free pairing again until settled; or, when no deformation predicts held-out
///            vessels better than none, the model back at rest in the start's frame (ε → ∞,
///            a SMOOTH stage of no iterations, vessel_compliance_ratio = +∞).
/// Each stage iterates Algorithm 1: pair the intra-operative points with the current model
/// features (vessel skeleton segments, collision-surface triangles), filter the pairs
/// (filtering.hpp), build the constraint rows (constraint_builders.hpp: vessels slide on the
/// skeleton's line; the probe footprint is unilateral; the dura holds the surface outside the
/// craniotomy; landmarks are points), take one constrained static step (constrained_step.hpp);
/// a stage settles when the largest nodal increment is below a tolerance (and, except HELD, the
/// pairing set is stable). A step whose increment is not finite ends the registration DIVERGED;
/// it never counts as converged. A DIVERGED stop returns the start's state (rigid pose plus the
/// bulk response to the start's bulk shift), an INSUFFICIENT_DATA one the rigid pose alone (the
/// rigid-only start: too few points for a bulk shift too; with a given pose, the pose plus the
/// bulk response); never a half-deformed one.
///
/// Trust region: each step is limited to a radius (StepOptions::max_increment, 5 mm by default)
/// that grows by 1.5× while the steps go on in the same direction. When a step turns back on the
/// previous one (negative cosine between successive nodal increments: oscillation) the radius
/// halves unless the oscillation clearly contracts: made with the same pairs as the previous
/// step, not limited, and its max nodal increment at most 0.9× the previous one's
/// (contraction_bound in registration_stage.hpp says why 0.9). Such a turn-back is a converging
/// oscillation and keeps the radius (HOLD): halving it there only races the convergence, and
/// the race, not the data, decided whether the loop converged or ended NOT_SETTLING. A reversal
/// (cosine ≤ −0.5) with the same pairs that does not contract and is below the radius is the
/// step's own overshoot (a period-2 oscillation of the corotational iteration, which halving
/// the radius cannot reach until it binds): the following steps are damped instead (DAMP: each
/// step scaled by α, α × 0.6 down to 0.2, for the rest of the stage; the stop test scales
/// with α). Constants and measurements in registration_stage.hpp.
/// A step that had to be limited never counts as converged; a radius below the increment
/// tolerance stops the loop with NOT_SETTLING and a diagnosis instead of oscillating.
///
/// Pairing cycles: with noisy points the nearest-feature pairing can cycle through a few sets
/// forever (a point between two segments, a tetrahedron whose nearest pair alternates). When the
/// pairing set changes to one already seen in an earlier iteration, the pairs are frozen: later
/// iterations keep each (point, feature) and only recompute the closest point on that feature,
/// so the mechanics can settle. The history says when this happened.
///
/// Frames: all positions in mm, world (RAS) frame of the pre-operative model. Intra-operative
/// points come in their own tracked frame; the start returns `rigid` with
/// p_model ≈ rigid · p_intra, and the deformation is then computed in the model frame:
/// a pre-operative point X is at rigid⁻¹ (X + u(X)) in the intra-operative frame.

#include "constraints/registration/registration_types.hpp"
#include "constraints/registration/start/start.hpp"

namespace brainshift::constraints {

/// The start alone: the global start (rigid, and the bulk response when
/// options.global_start.bulk_response) and its state — the rest nodes plus the bulk response to
/// the start's bulk shift, in the model frame — with no loop. The "start only" baseline of the
/// benchmark (`bulk_start_only`); stop CONVERGED, or NO_DATA without vessel points.
/// \throws brainshift::Error as register_model().
RegistrationResult start_only(const RegistrationModel& model, const IntraopData& data,
                              const RegistrationOptions& options);

/// Runs the registration.
/// @param[in] model the prepared model; only read (one model serves any number of registrations).
/// @param[in] initial warm start: a previous result (its positions, rigid transform and λ are
/// reused; the rigid fit is then skipped) or nullptr for the rest shape. A warm start that does
/// not converge is retried cold (options.cold_retry).
/// A stop that cannot be trusted returns the start's state (DIVERGED: rigid + bulk response;
/// INSUFFICIENT_DATA: the rigid-only pose), never a half-deformed one
/// (RegistrationResult::start_returned).
/// \throws brainshift::Error on invalid options or non-finite / mis-sized inputs. A registration
/// that does not converge is a status (stop, stop_reason), never an exception; positions are
/// always finite.
RegistrationResult register_model(const RegistrationModel& model, const IntraopData& data,
                                  const RegistrationOptions& options,
                                  const RegistrationResult* initial = nullptr);

}  // namespace brainshift::constraints
