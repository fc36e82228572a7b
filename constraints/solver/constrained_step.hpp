#pragma once
/// @file
/// @brief One constrained static step (seed 002 eq. 6 solved by a Schur complement with
/// compliance warping; Algorithm 1 step 4):
///   free motion  dx_free = C (f_ext − f_int(x)),        C = R K0⁻¹ Rᵀ,
///   constraints  δ_free = δ + H dx_free,  W = H C Hᵀ,  λ = PGS(W, δ_free),
///   correction   dx = dx_free + C Hᵀ λ,                 x ← x + dx.
/// Repeating the step (re-building the rows at the new x) converges to the corotational
/// equilibrium that satisfies the constraints.

#include "constraints/rows/constraint_rows.hpp"
#include "constraints/solver/active_set.hpp"
#include "constraints/solver/compliance_operator.hpp"
#include "constraints/solver/pgs.hpp"
#include "core/assembly/dof_map.hpp"
#include "core/fem/corotational.hpp"
#include "core/mesh/tet_mesh.hpp"
#include "core/solver/cholmod_factor.hpp"

#include <array>
#include <memory>
#include <vector>

namespace brainshift::constraints {

/// How the step treats rotations.
enum class Mechanics {
  WARPED,    ///< corotational forces, warped compliance R K0⁻¹ Rᵀ (the method)
  UNWARPED,  ///< corotational forces, unwarped compliance K0⁻¹ (SOFA's regression; ablation)
  LINEAR,    ///< linear forces K0 (x − X) and K0⁻¹ (small-strain FEM; ablation)
  EXACT,  ///< corotational forces, exact rotated tangent K(R) = Σ R̂ₑ Kₑ R̂ₑᵀ refactorised
          ///< every step (reference for tests and benchmarks; not the fast path)
};
std::string to_string(Mechanics m);
/// Names of Mechanics in the scene, reports and the command line.
constexpr std::array<core::EnumName<Mechanics>, 4> enum_names(Mechanics /*tag*/) {
  return {{{Mechanics::WARPED, "warped"},
           {Mechanics::UNWARPED, "unwarped"},
           {Mechanics::LINEAR, "linear"},
           {Mechanics::EXACT, "exact"}}};
}

struct StepOptions {
  PgsOptions pgs;
  ConstraintSolver solver = ConstraintSolver::AUTO;  ///< direct active set or PGS (active_set.hpp)
  Mechanics mechanics = Mechanics::WARPED;
  Vector3d gravity = Vector3d::Zero();  ///< body acceleration, mm/s²
  double density = 1040e-9;             ///< kg/mm³
  /// Trust region: when > 0 and the step would move a node by more than this (mm), the whole
  /// increment is scaled down to it (the constraints are then met over several steps). Large
  /// rotations reached in one linearised step overshoot the corotational quasi-Newton iteration;
  /// limiting the step keeps it convergent.
  double max_increment = 0.0;
  /// Compliant (soft) rows, per constraint set (indexed by ConstraintSet): row i of set s gets
  /// the compliance εᵢ = compliance_ratio[s] · median(diag W) added to Wᵢᵢ, so the law becomes
  /// gᵢ + εᵢ λᵢ = 0 (a spring of stiffness 1/εᵢ instead of a hard constraint). 0 = hard.
  /// Relative to W's diagonal so it is independent of the tissue's modulus and the mesh size.
  /// Noisy targets (0.3 mm Doppler noise, 7 mm elements) make hard rows fit the noise with large
  /// local strains and antagonistic pulls; a ratio of 0.1–1 averages the noise over neighbours
  /// while a smooth shift is still met (its compliance is far below a point load's Wᵢᵢ).
  std::array<double, num_constraint_sets> compliance_ratio{};
  /// Violations beyond this (mm) are flagged in StepResult::diagnosis (mis-pairing, wrong frame).
  /// Not a scene key.
  double plausible_violation = 100.0;
  /// Keep the Delassus operator (without the row compliance) and δ_free in the result, for the
  /// registration's noise model (noise_model.hpp).
  bool keep_system = false;
  /// The elastic rest of the step's forces and rotations (core::RestShape, a pre-strained
  /// state); null: the mesh's rest. Not an option: the registration sets it for its bulk load
  /// (RegistrationOptions::bulk_as_load). LINEAR measures u from its nodes too.
  std::shared_ptr<const core::RestShape> rest;
};

/// The options' names, ranges and documentation (core/option_fields.hpp); in the scene under
/// solver. `keep_system` and `rest` are not options (the registration loop sets them: the system
/// for its noise model, the rest for its bulk load); `plausible_violation` is a constant.
template <class V>
void visit_fields(StepOptions& o, V&& v) {
  v("trust_region_mm", o.max_increment, core::Range{0, 1000},
    "largest nodal move of one step (mm); 0: unlimited");
  v("constraint_solver", o.solver, "direct active set, Gauss-Seidel, or auto (by the row count)");
  v("mechanics", o.mechanics, "how the step treats rotations");
  auto& ratio = o.compliance_ratio;
  v("compliance.vessels", ratio[static_cast<std::size_t>(ConstraintSet::VESSELS)],
    core::Range{0, 1000}, "compliance of the vessel rows / median diag W; 0: hard");
  v("compliance.footprint", ratio[static_cast<std::size_t>(ConstraintSet::FOOTPRINT)],
    core::Range{0, 1000}, "compliance of the footprint rows / median diag W; 0: hard");
  v("compliance.dura", ratio[static_cast<std::size_t>(ConstraintSet::DURA)], core::Range{0, 1000},
    "compliance of the dura rows / median diag W; 0: hard");
  v("compliance.landmarks", ratio[static_cast<std::size_t>(ConstraintSet::LANDMARK)],
    core::Range{0, 1000}, "compliance of the landmark rows / median diag W; 0: hard");
  v("gravity_mm_s2", o.gravity, "body acceleration (mm/s^2, world RAS)");
  v("density_kg_mm3", o.density, core::Range{0, 1}, "tissue density (kg/mm^3)");
  v.nest("pgs_", o.pgs);
}

struct StepResult {
  MatrixX3d x;             ///< new nodal positions (#N×3, mm)
  Eigen::VectorXd lambda;  ///< constraint forces (#rows, mN)
  PgsResult pgs;
  double max_increment = 0.0;     ///< max nodal |Δx| of this step (after limiting), mm
  bool limited = false;           ///< the increment was scaled down to StepOptions::max_increment
  double uncut_increment = 0.0;   ///< max nodal |Δx| before the limit (mm; the radius's cut)
  index_t inverted_elements = 0;  ///< at the start of the step
  /// False when the increment was not finite (a diverging iteration): the step is then rejected,
  /// x is the input positions unchanged and the caller must stop (never count it as converged).
  bool finite = true;
  bool delassus_fallback = false;  ///< W needed sparse solves (rows outside the compliance block)
  Eigen::MatrixXd delassus;    ///< W = H C Hᵀ without row compliance (StepOptions::keep_system)
  Eigen::VectorXd delta_free;  ///< δ + H dx_free (StepOptions::keep_system)
  double compliance_scale = 0.0;  ///< median diag W: the unit of StepOptions::compliance_ratio
  std::string diagnosis;          ///< empty, or one line on what looks wrong (huge violations,
                                  ///< inverted elements, rows ignored or inconsistent)
  double seconds_free_motion = 0.0, seconds_delassus = 0.0, seconds_pgs = 0.0,
         seconds_correction = 0.0;
};

/// A mechanical model prepared for constrained steps: K0 assembled and factorised once (CHOLMOD),
/// compliance block precomputed when the budget allows. Reused across steps and registrations.
class ConstrainedModel {
 public:
  /// @param[in] mesh rest mesh (validated). @param[in] fixed_nodes Dirichlet nodes (displacement
  /// 0).
  /// @param[in] block_nodes nodes constraints may touch (dense compliance block); may be empty.
  /// \throws brainshift::Error when K0_ff cannot be factorised (e.g. no fixed nodes: the rigid
  /// modes make it singular), naming the cause.
  ConstrainedModel(const core::TetMesh& mesh, const std::vector<index_t>& fixed_nodes,
                   std::vector<index_t> block_nodes, const ComplianceOptions& compliance = {});

  /// One step from positions x (#N×3) with rows built at x. Const: the rotations of x are
  /// computed and used within the call, so one prepared model serves any number of
  /// registrations (replay, bench) without carrying state from one to the next.
  [[nodiscard]] StepResult step(ConstRef<MatrixX3d> x, const ConstraintRows& rows,
                                const StepOptions& options,
                                ConstRef<Eigen::VectorXd> warm_start = Eigen::VectorXd()) const;

  [[nodiscard]] const core::CorotationalModel& model() const { return m_model; }
  [[nodiscard]] const core::DofMap& dofs() const { return m_dofs; }
  [[nodiscard]] const core::CholmodFactor& factor() const { return *m_factor; }
  [[nodiscard]] ComplianceOperator& compliance() { return *m_compliance; }
  [[nodiscard]] const ComplianceOperator& compliance() const { return *m_compliance; }
  [[nodiscard]] const SparseMatrix& rest_stiffness() const { return m_K0; }

 private:
  core::CorotationalModel m_model;
  core::DofMap m_dofs;
  SparseMatrix m_K0;
  std::unique_ptr<core::CholmodFactor> m_factor;  // stable address for m_compliance
  std::unique_ptr<ComplianceOperator> m_compliance;
};

}  // namespace brainshift::constraints
