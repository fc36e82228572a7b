#pragma once
/// @file
/// @brief Rigid initialisation (issue 4 item 5): robust ICP of the intra-operative vessel points
/// onto the pre-operative vessel skeleton (point-to-line), optionally with footprint points onto
/// a triangle surface (point-to-plane). Positions in mm, world (RAS) frame.
///
/// Each ICP iteration pairs every transformed point T pᵢ with its closest skeleton segment
/// (closest point qᵢ, unit tangent tᵢ) or surface triangle (closest point qⱼ, unit normal nⱼ),
/// drops pairs farther than `max_pair_distance_mm`, and then minimises with Ceres
///   E(R, t) = Σᵢ ρ(‖(I − tᵢtᵢᵀ)(T pᵢ − qᵢ)‖²) + w_f Σⱼ ρ((nⱼ·(T pⱼ − qⱼ))²),
///   T p = R (p − c) + c + t,  R = exp([ω]×) (angle-axis ω, 3) , t (3),
/// with c the centroid of the intra-operative points and ρ the Huber or Cauchy loss of scale
/// `loss_scale_mm` (ρ(s) = s for NONE). Point-to-line: Chen & Medioni 1992 / Censi 2008 (PLICP);
/// robust kernels: Babin et al., "Analysis of robust functions for registration algorithms",
/// ICRA 2019. The loop stops when the transform changes by less than `convergence_mm` (change
/// of translation at c plus rotation angle times the RMS radius of the points about c).
///
/// Observability: the Gauss–Newton information matrix H = Σ wᵢ Jᵢᵀ Jᵢ (6×6, rotation columns
/// scaled by the RMS radius so that all six are in mm) is reported through its condition
/// number; eigen-directions with λ < weak_dof_ratio · λ_max are named in `weak_dofs` (e.g. the
/// rotation about, and translation along, a single straight vessel).

#include "core/config.hpp"
#include "core/geometry/skeleton.hpp"
#include "core/option_fields.hpp"

#include <string>

namespace brainshift::constraints {

/// Options of rigid_init().
struct RigidInitOptions {
  enum class Loss { HUBER, CAUCHY, NONE };
  Loss loss = Loss::HUBER;  ///< robust loss on the point-to-feature distance
  double loss_scale_mm =
      2.0;  ///< loss scale k (mm): Huber is quadratic below k; Cauchy ρ = k² log(1 + d²/k²)
  int max_icp_iterations = 50;         ///< cap on pair/solve rounds
  double max_pair_distance_mm = 20.0;  ///< pairs farther than this (mm) are dropped each round
  double footprint_weight = 1.0;  ///< w_f, weight of each footprint pair relative to a vessel pair
  double convergence_mm =
      1e-3;  ///< stop when the transform change (mm, see file doc) is below this
  int max_solver_iterations = 20;  ///< Ceres Levenberg–Marquardt iterations per ICP round
  double weak_dof_ratio = 1e-3;    ///< λ/λ_max below which a DOF is reported as weakly determined

  /// Empty when valid, else what is wrong and how to fix it.
  [[nodiscard]] std::string validate() const;
};

/// Names of RigidInitOptions::Loss in the scene, reports and the command line.
constexpr std::array<core::EnumName<RigidInitOptions::Loss>, 3> enum_names(
    RigidInitOptions::Loss /*tag*/) {
  return {{{RigidInitOptions::Loss::HUBER, "huber"},
           {RigidInitOptions::Loss::CAUCHY, "cauchy"},
           {RigidInitOptions::Loss::NONE, "none"}}};
}

/// The options' names, ranges and documentation (core/option_fields.hpp); in the scene under rigid.
template <class V>
void visit_fields(RigidInitOptions& o, V&& v) {
  v("loss", o.loss, "robust loss on the point-to-feature distance");
  v("loss_scale_mm", o.loss_scale_mm, core::Range{1e-6, 1000}, "scale k of the loss (mm)");
  v("max_icp_iterations", o.max_icp_iterations, core::Range{1, 10000}, "pair/solve rounds");
  v("max_pair_distance_mm", o.max_pair_distance_mm, core::Range{1e-6, 1000},
    "pairs farther than this are dropped each round (mm)");
  v("footprint_weight", o.footprint_weight, core::Range{0, 1e6},
    "weight of a footprint pair relative to a vessel pair");
  v("convergence_mm", o.convergence_mm, core::Range{1e-12, 100},
    "stop when the transform changes by less than this (mm)");
  v("max_solver_iterations", o.max_solver_iterations, core::Range{1, 10000},
    "Levenberg-Marquardt iterations per round");
  v("weak_dof_ratio", o.weak_dof_ratio, core::Range{1e-12, 0.999999},
    "lambda / lambda_max below which a degree of freedom is reported weak");
}

/// Outcome of rigid_init(). Numbers are always finite.
struct RigidInitResult {
  /// Maps intra-operative points into the pre-operative frame: p_pre ≈ transform · p_intra.
  Eigen::Isometry3d transform = Eigen::Isometry3d::Identity();
  int iterations = 0;             ///< ICP rounds performed
  bool converged = false;         ///< transform change fell below convergence_mm
  std::string stop_reason;        ///< why the loop stopped, plus weakly determined DOFs if any
  double rms_before_mm = 0.0;     ///< RMS point-to-feature distance of the pairs at the identity
  double rms_after_mm = 0.0;      ///< same at the final transform (outliers included)
  index_t pairs_used = 0;         ///< pairs (vessel + footprint) in the last round
  double condition_number = 0.0;  ///< λ_max/λ_min of the scaled 6×6 information matrix (≤ 1/ε)
  int weak_dof_count = 0;         ///< eigen-directions with λ < weak_dof_ratio·λ_max
  std::string weak_dofs;          ///< e.g. "rotation about (0.00, 0.00, 1.00)"; empty when none
};

/// Rigid initialisation by robust point-to-line (+ point-to-plane) ICP; see the file doc.
/// @param[in] skeleton  pre-operative vessel skeleton (points #P×3 mm, segments), world frame
/// @param[in] vessel_points  intra-operative vessel points (#N×3, mm, world frame)
/// @param[in] surface  pre-operative surface for the footprint, or nullptr (not owned; only read
///                     during the call)
/// @param[in] footprint_points  intra-operative footprint points (#M×3, mm), or nullptr; used
///                     only with a surface
/// @param[in] options  see RigidInitOptions
/// @return the transform and the convergence report. No points, no skeleton or too few pairs
///         give the identity with converged = false and a stop_reason saying why.
/// \throws brainshift::Error when options.validate() fails, indices are out of range, inputs
///         are not finite, or footprint points are given without a surface.
RigidInitResult rigid_init(const core::Skeleton& skeleton, ConstRef<MatrixX3d> vessel_points,
                           const core::SurfaceMesh* surface, const MatrixX3d* footprint_points,
                           const RigidInitOptions& options);

}  // namespace brainshift::constraints
