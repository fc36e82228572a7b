#pragma once
/// @file
/// @brief The truth solver: total-Lagrangian explicit dynamics (TLED) on linear tetrahedra with
/// the neo-Hookean material of neo_hookean.hpp, driven to the static solution by dynamic
/// relaxation (Joldes, Wittek, Miller 2009, "Computation of intra-operative brain shift using
/// dynamic relaxation", CMAME 198; seed 001 §2.3).
///
/// Per element e (constant strain): F = I + Σ_a u_a ⊗ ∇N_a, nodal forces f_a = V_e P(F) ∇N_a
/// (shape gradients and rest volumes precomputed; total Lagrangian). The damped explicit central-
/// difference scheme M ü + c M u̇ + f_int(u) = f_ext with lumped mass is, per node,
///   u⁽ⁿ⁺¹⁾ = u⁽ⁿ⁾ + β (u⁽ⁿ⁾ − u⁽ⁿ⁻¹⁾) + α M⁻¹ (f_ext − f_int(u⁽ⁿ⁾)),
///   α = 2Δt² / (2 + cΔt),  β = (2 − cΔt) / (2 + cΔt).
/// Since only the static answer is wanted the masses are scaled (m_i = the Gershgorin bound of
/// node i's rows of the rest stiffness, so λ_max(M⁻¹K₀) ≤ 1) and α, β are chosen from the bounds
/// [λ_min, λ_max] of M⁻¹K for the fastest decay (optimal damping):
///   α = 4 / (√λ_max + √λ_min)²,  β = ((√λ_max − √λ_min) / (√λ_max + √λ_min))²,
/// with λ_max = stiffness_safety (headroom for stiffening) and λ_min re-estimated during the run
/// by the Rayleigh quotient Δuᵀ Δf_int / Δuᵀ M Δu of the last increment (Joldes et al.).
/// Stopping: the estimated error ‖u − u*‖_∞ ≤ ρ/(1 − ρ) ‖u⁽ⁿ⁺¹⁾ − u⁽ⁿ⁾‖_∞, with ρ the larger of
/// the convergence rate predicted from λ_min, α, β and the rate observed over a window.
///
/// Contact: frictionless, kinematic (Joldes et al. 2009): a candidate node that leaves the rigid
/// skull ellipsoid (outside its opening) is put back on the closest skull point and its outward
/// normal velocity is removed. With a hull (a distance field: the skull of a label anatomy) the
/// skull is its zero level instead; a node that rests outside it (a stair corner of the voxel
/// truth mesh) may not move further out than where it rests.

#include "core/config.hpp"
#include "core/mesh/tet_mesh.hpp"
#include "data_synth/geometry/distance_field.hpp"
#include "data_synth/geometry/ellipsoid.hpp"
#include "data_synth/truth/neo_hookean.hpp"

#include <array>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace brainshift::data_synth {

/// Prescribed displacement components of one node (world frame, mm).
struct NodeConstraint {
  index_t node = -1;
  std::array<bool, 3> fixed{true, true, true};  ///< which components (x, y, z) are prescribed
  Vector3d displacement = Vector3d::Zero();     ///< values of the prescribed components, mm
};

/// Rigid skull with an opening (the craniotomy): nodes may not leave the ellipsoid except
/// where the closest skull point is within opening_radius of opening_centre.
struct SkullContact {
  Ellipsoid skull;  ///< world RAS mm (unused with a hull)
  /// The skull as the zero level of a signed distance field (mm, negative inside) instead of the
  /// ellipsoid: the brain's outer surface grown by the CSF gap (label anatomies).
  std::shared_ptr<const DistanceField> hull;
  Vector3d opening_centre = Vector3d::Zero();  ///< on the skull, mm
  double opening_radius = 0.0;                 ///< mm, ≥ 0 (0: closed skull)
  std::vector<index_t> candidate_nodes;        ///< nodes that can touch the skull (empty: all)
};

/// What to solve: loads, prescribed displacements, contact.
struct TledProblem {
  MatrixX3d external_force;                 ///< #N×3 nodal forces, mN (empty: none)
  std::vector<NodeConstraint> constraints;  ///< must remove the rigid modes unless contact does
  std::optional<SkullContact> contact;
};

struct TledOptions {
  int max_iterations = 100000;       ///< cap on explicit steps
  double error_tolerance = 1e-3;     ///< mm: stop when the estimated max nodal error is below this
  int ramp_iterations = 200;         ///< loads and prescribed displacements ramp linearly, ≥ 1
  double stiffness_safety = 1.3;     ///< λ_max used = this × the rest Gershgorin bound, ≥ 1
  int damping_update_interval = 20;  ///< re-estimate λ_min every this many steps, ≥ 1
  int rate_window = 50;  ///< steps over which the observed convergence rate is taken, ≥ 2
  /// The error estimate must hold this many steps in a row, ≥ 1. A full rate window guards
  /// against the optimistic estimate of the first steps after the ramp (on the phantom, 10
  /// steps stopped with a true error twice the tolerance; 50 keeps it below the tolerance).
  int converged_steps = 50;
  double divergence_displacement = 1e4;  ///< mm: |u| beyond this means divergence
  /// Empty when valid, else the reason.
  [[nodiscard]] std::string validate() const;
};

enum class TledStatus {
  CONVERGED,       ///< estimated error below tolerance
  MAX_ITERATIONS,  ///< cap reached; the last (finite) iterate is returned
  DIVERGED,  ///< non-finite value, inverted element or runaway displacement; last finite iterate
};
std::string to_string(TledStatus status);

struct TledResult {
  TledStatus status = TledStatus::DIVERGED;
  std::string message;     ///< one line: why it stopped
  MatrixX3d displacement;  ///< #N×3, mm, always finite
  int iterations = 0;
  double estimated_error = 0.0;   ///< mm, ρ/(1−ρ)·last max nodal increment
  double max_displacement = 0.0;  ///< max nodal |u|, mm
  double convergence_rate = 0.0;  ///< ρ used by the last error estimate
  double lambda_min = 0.0;    ///< last estimate of λ_min(M⁻¹K), dimensionless (λ_max ≤ 1)
  index_t contact_nodes = 0;  ///< nodes held on the skull at the last step
  double min_jacobian = 0.0;  ///< smallest det F over the elements
};

/// Prepared TLED solver: shape gradients, volumes, materials and scaled masses of a mesh.
/// Holds its data by value.
class TledSolver {
 public:
  /// Materials from the mesh's E and ν per tetrahedron (NeoHookean::from_youngs).
  /// \throws brainshift::Error if the mesh is invalid (core::validate).
  explicit TledSolver(const core::TetMesh& mesh);

  [[nodiscard]] index_t num_nodes() const { return m_num_nodes; }
  /// Scaled lumped masses (Gershgorin bounds of K₀'s rows), mN/mm: no physical meaning.
  [[nodiscard]] const Eigen::VectorXd& scaled_mass() const { return m_mass; }

  /// Internal force f_int(u) = ∂Ψ/∂u (#N×3, mN) at displacement u (#N×3, mm).
  /// @param[out] min_jacobian  smallest det F (optional). Elements with det F ≤ 0 give NaN forces.
  [[nodiscard]] MatrixX3d internal_force(ConstRef<MatrixX3d> u,
                                         double* min_jacobian = nullptr) const;
  /// Total strain energy Ψ(u) = Σ V_e W(F_e), mJ (= mN·mm); +∞ if an element is inverted.
  [[nodiscard]] double strain_energy(ConstRef<MatrixX3d> u) const;

  /// Runs dynamic relaxation from u = 0. \throws brainshift::Error on invalid options or a
  /// problem whose sizes or node indices do not match the mesh; numerical failure is a status.
  [[nodiscard]] TledResult solve(const TledProblem& problem, const TledOptions& options) const;

 private:
  /// f += f_int(u); returns the smallest det F.
  double add_internal_force(const MatrixX3d& u, MatrixX3d& f) const;

  index_t m_num_nodes = 0;
  MatrixX3d m_rest;  ///< rest positions, mm
  MatrixX4i m_tets;
  std::vector<Eigen::Matrix<double, 3, 4>> m_grad;  ///< columns ∇N_a, 1/mm
  std::vector<double> m_volume;                     ///< mm³
  std::vector<NeoHookean> m_material;
  Eigen::VectorXd m_mass;
};

}  // namespace brainshift::data_synth
