#pragma once
/// @file
/// @brief Loads and boundary conditions of the brain-sag truth case (gravity and loss of CSF
/// buoyancy after a craniotomy) on a phantom mesh.
///
/// Model. Before surgery the brain floats in CSF: the net body force (ρ_brain − ρ_csf) g is small
/// and already in equilibrium in the pre-operative image, which is taken as the stress-free
/// reference (pre-stress neglected). Opening the skull drains the CSF down to a level: the fluid
/// surface is the plane perpendicular to g at `drain_depth` below the brain's highest point
/// (measured against g). Tissue above that plane loses its buoyancy, i.e. gains the body force
/// ρ_csf g; below it nothing changes. The load of the truth solve is this change only (plus,
/// optionally, the pre-operative net weight). Nodal forces are lumped: each tetrahedron gives a
/// quarter of its volume to each node, and a node is loaded when it lies above the fluid surface.
/// Boundary: the nodes of the flattened base (skull base, brainstem) are fixed; the rest of the
/// surface slides without friction on the rigid skull ellipsoid except under the craniotomy.

#include "core/mesh/tet_mesh.hpp"
#include "core/units.hpp"
#include "data_synth/geometry/brain_phantom.hpp"
#include "data_synth/geometry/phantom_mesh.hpp"
#include "data_synth/truth/tled_solver.hpp"

#include <string>

namespace brainshift::data_synth {

struct SagLoad {
  Vector3d gravity_direction{0.0, 0.0, -1.0};   ///< world RAS, any length > 0 (normalised)
  double gravity = units::standard_gravity;     ///< mm/s²
  double csf_density = units::csf_density;      ///< kg/mm³
  double brain_density = units::brain_density;  ///< kg/mm³ (used by the pre-operative weight)
  /// Depth of the CSF surface below the brain's highest point along −g, mm, ≥ 0
  /// (0: nothing drained; ≥ the brain's height: fully drained).
  double drain_depth = 60.0;
  bool include_preoperative_weight = false;  ///< also apply (ρ_brain − ρ_csf) g everywhere
  double load_scale = 1.0;                   ///< multiplies every force (small-load tests), ≥ 0
  /// Empty when valid, else the reason.
  [[nodiscard]] std::string validate() const;
};

/// Nodal body forces of the sag case (#N×3, mN). \throws brainshift::Error on an invalid load.
MatrixX3d sag_nodal_force(const core::TetMesh& mesh, const SagLoad& load);

/// The full sag problem on a phantom mesh: forces, base nodes fixed, skull contact with the
/// craniotomy opening, surface nodes as contact candidates.
TledProblem make_sag_problem(const PhantomGeometry& geometry, const PhantomMesh& mesh,
                             const SagLoad& load);

}  // namespace brainshift::data_synth
