#pragma once
/// @file
/// @brief Predicted error of a registration: the posterior covariance of the nodal
/// displacement under the linear-Gaussian reading of the registration's own MAP problem.
///
/// Model (the same one noise_model.hpp reads the vessel compliance from): the displacement has
/// the elastic prior u ~ N(0, s² C), C = R K0⁻¹ Rᵀ the warped compliance at the final rotations
/// (mm/mN), and the data rows (vessels, footprint, landmarks; linearised at the final state)
/// observe δ_free = H u + e with e ~ N(0, s² A), A = diag(εᵢ) the rows' compliance. Then
///   Σ(x) = s² (J_x C J_xᵀ − J_x C Hᵀ (H C Hᵀ + A)⁻¹ H C J_xᵀ + R_x M⁺ R_xᵀ)      (mm²)
/// and the predicted error at x is sqrt(tr Σ(x)) (mm): the RMS length of the 3-D error vector.
///
/// The last term (the rigid term, UncertaintyOptions::rigid_term) is what the pose of the
/// registration's rigid start adds: the start estimates the pose from the same rows, so the pose
/// is an unknown of the model with a flat prior (universal kriging: the displacement is
/// h_x θ + R u, θ = (translation, small rotation about the rows' centroid c), h_x =
/// [I, −[x − c]×]). With Gr the rows' sensitivities to θ (m×6), S = H C Hᵀ + A and
/// M = Grᵀ S⁻¹ Gr, R_x = h_x − J_x C Hᵀ S⁻¹ Gr: small where the rows pin the pose and the
/// deformation together, growing with the lever arm from the rows (a rotation error), also on
/// the fixed nodes (they move with the pose). Directions of θ the rows cannot determine are
/// left out (pseudo-inverse; NodalVariance::rigid_rank says how many are determined).
///
/// How the pieces are computed (cost grows like the registration's: sparse solves with the
/// factor it already has):
/// - per node n, tr(R_n M R_nᵀ) = tr M, so the nodal traces need the unrotated K0⁻¹ only; the
///   rotations enter through the rows (H R);
/// - the data term: Y = K0⁻¹ (H R)ᵀ by one multi-right-hand-side solve (#rows columns), then
///   tr(Y_n (W + A)⁻¹ Y_nᵀ) for every node from one Cholesky factor of W + A (#rows²);
/// - the prior term tr(K0⁻¹)_nn: exact where the dense compliance block (compliance_operator.hpp,
///   K0⁻¹ on every node a vessel or surface point maps to, precomputed before surgery) holds it;
///   elsewhere exact by unit loads solved in blocks on a coarse set of nodes (one per cell of a
///   grid of `coarse_spacing_mm` holding no exact node yet, plus any node a data row touches), and
///   interpolated to the remaining nodes by inverse-distance weighting of the 4 nearest exact
///   nodes (the prior's trace varies slowly: it grows with the distance from the fixed region).
///   A stochastic (Hutchinson) estimator is not used: K0⁻¹ is a dense Green's function (~1/r),
///   whose off-diagonal mass makes the estimate's relative error O(1) at any affordable number of
///   probes, while unit loads on the coarse set are exact at the same cost.
/// - fixed nodes have zero deformable variance (their DOFs are eliminated); the rigid term only.
///
/// Rows that are not data: dura rows (a boundary condition of the model, not a measurement) are
/// not used, and neither are unilateral footprint rows that are separated at the final state
/// (inactive). Hard rows (compliance 0: footprint, landmarks) get a floor compliance of
/// `hard_row_ratio` × median diag W so the data covariance stays invertible.
///
/// s² (mN·mm) and α: α is the compliance the registration used (the vessel rows' ratio ×
/// median diag W, as in StepOptions::compliance_ratio), and s² is the maximum-likelihood scale of
/// the linear-Gaussian model, δ_free ~ N(0, s² (W + A)): s² = δ_freeᵀ (W + A)⁻¹ δ_free / m
/// (m rows), with δ_free what the rows would be violated by if the model relaxed to its unloaded
/// shape at the final rotations (the default). Also computed, as diagnostics and options
/// (UncertaintyOptions::scale_estimator): the discrepancy principle; the restricted ML
/// δᵀ P δ / (m − rank M), P = S⁻¹ − S⁻¹ Gr M⁺ Grᵀ S⁻¹ (pose projected out); and the scale from
/// held-out vessel blocks (vessel_blocks.hpp; closed-form leave-one-block-out of the linear-
/// Gaussian fit: w = P δ, Σ_b w_bᵀ (P_bb)⁺ w_b / Σ_b rank P_bb). The default (BY_POSE) takes ML
/// when the pose was searched on this sweep and the held-out scale when it was given (a pre-dura
/// sweep's): with a searched pose ML with the rigid term measured best
/// (docs/history/BENCHMARKS_NOTEBOOK.md, "Predicted error": the held-out scale matches ML where
/// the model fits and is lower on deep_tumour_one_side_vessels, where it under-predicts); with a
/// given pose δ_free holds the whole sag and ML measures its size, not the fit's error
/// (UncertaintyOptions::ScaleEstimator). `calibration` (dimensionless, default 1) multiplies s².
/// The chosen estimate is then raised to its one-sided upper confidence bound (`scale_confidence`,
/// default 0.95): k ŝ² / χ²_{1−c}(k), k the held-out vessel blocks (else the rows): few vessels, a
/// wider map. The stated tracking accuracy (uncertainty_options.hpp; default 0) adds a rigid-pose
/// covariance about the rows' centroid that no row can show: tracking_variance(), not scaled.
/// Positions in mm, model (pre-operative, world RAS) frame.

#include "constraints/registration/registration_types.hpp"
#include "constraints/registration/uncertainty/uncertainty_options.hpp"
#include "core/assembly/dof_map.hpp"
#include "core/solver/cholmod_factor.hpp"

#include <string>
#include <vector>

namespace brainshift::constraints {

/// Traces of the nodal covariance blocks, without the scale s² (mm/mN).
struct NodalVariance {
  Eigen::VectorXd prior;  ///< #N: tr (K0⁻¹)_nn (interpolated off the coarse set); 0 on fixed nodes
  Eigen::VectorXd posterior;  ///< #N: prior − data term, clamped at 0
  index_t exact_nodes = 0;    ///< nodes whose prior term is exact (known or solved for)
  index_t solved_nodes = 0;   ///< of them, solved for here (3 unit loads each)
  double scale = 0.0;         ///< median diag(Gᵀ K0⁻¹ G) (mm/mN; 0 without rows)
  double quadratic = 0.0;     ///< δᵀ (W + A)⁻¹ δ when NodalVarianceExtras::delta was given
  double residual_sq = 0.0;  ///< ‖A (W + A)⁻¹ δ‖²: the fitted rows' residual (mm²), with delta
  double residual_dof = 0.0;  ///< tr(A (W + A)⁻¹ A) (mm²/(mN·mm)): E‖r‖² = s² × this
  /// #N: the rigid term tr(R_n M⁺ R_nᵀ) (mm/mN) with NodalVarianceExtras::rigid_rows (else 0):
  /// the variance the unknown pose of the rigid start adds (see predict_uncertainty()).
  Eigen::VectorXd rigid;
  index_t rigid_rank = 0;  ///< rank of M = Grᵀ (W + A)⁻¹ Gr (≤ 6; 0 without rigid_rows)
  double restricted_quadratic = 0.0;  ///< δᵀ P δ, P = S⁻¹ − S⁻¹ Gr M⁺ Grᵀ S⁻¹ (S⁻¹ without Gr)
  double heldout_quadratic = 0.0;  ///< Σ_b w_bᵀ (P_bb)⁺ w_b, w = P δ, over the held-out blocks
  double heldout_rows = 0.0;       ///< rows in the held-out blocks (Σ_b rank P_bb)
  index_t heldout_blocks = 0;      ///< blocks held out
};

/// Optional inputs of nodal_variance().
struct NodalVarianceExtras {
  /// #N: tr (K0⁻¹)_nn where already known (e.g. from the dense compliance block), < 0 elsewhere.
  const Eigen::VectorXd* known_prior = nullptr;
  /// `noise` is relative: A = noise × median diag W (as StepOptions::compliance_ratio).
  bool noise_relative = false;
  /// Row values δ (m): NodalVariance::quadratic is then δᵀ (W + A)⁻¹ δ.
  const Eigen::VectorXd* delta = nullptr;
  /// m×6: each row's sensitivity to a small rigid motion of the whole model, g_jᵀ = [d_jᵀ,
  /// ((p_j − c) × d_j)ᵀ] (translation mm, rotation rad about c): with it the rigid pose is an
  /// unknown of the model with a flat prior (NodalVariance::rigid, restricted_quadratic).
  const Eigen::MatrixXd* rigid_rows = nullptr;
  /// #N×3 points (mm) where the rigid basis h_n = [I, −[x_n − c]×] is evaluated, and c (mm); with
  /// rigid_rows.
  const MatrixX3d* rigid_points = nullptr;
  Vector3d rigid_centre = Vector3d::Zero();
  /// #N rotations taking a node's frame of K0⁻¹ to the rigid basis' frame (identity if null).
  const std::vector<Matrix3d>* node_rotations = nullptr;
  /// m block ids (≥ 0: held out together to give NodalVariance::heldout_*; < 0: never held
  /// out), with delta.
  const std::vector<index_t>* blocks = nullptr;
};

/// The nodal traces of K0⁻¹ − K0⁻¹ G (Gᵀ K0⁻¹ G + diag(noise))⁻¹ Gᵀ K0⁻¹.
/// @param[in] factor CHOLMOD factor of K0_ff (free DOFs of `dofs`).
/// @param[in] dofs the DOF map (fixed nodes: zero deformable variance).
/// @param[in] nodes #N×3 rest positions (mm), for the coarse grid and the interpolation.
/// @param[in] G #free × m: the data rows, transposed, on the free DOFs (may have 0 columns).
/// @param[in] noise m compliances (mm/mN, > 0).
/// \throws brainshift::Error on mismatched sizes or a non-positive noise entry.
NodalVariance nodal_variance(const core::CholmodFactor& factor, const core::DofMap& dofs,
                             ConstRef<MatrixX3d> nodes, const SparseMatrix& G,
                             const Eigen::VectorXd& noise, const UncertaintyOptions& options,
                             const NodalVarianceExtras& extras = {});

/// The p-quantile of the χ² distribution with k (> 0, not necessarily integer) degrees of
/// freedom, by bisection on the regularised incomplete gamma function (relative error < 1e-12).
/// \throws brainshift::Error unless k > 0 and 0 < p < 1.
double chi2_quantile(double k, double p);

/// The predicted error of a registration.
struct UncertaintyResult {
  bool estimated = false;         ///< s² came from the data (false: no data rows; see estimation)
  Eigen::VectorXd node_sigma_mm;  ///< #N: sqrt(tr Σ_n), mm; the rigid term alone on fixed nodes
  /// #N: the confounded pose's term, mm² (UncertaintyOptions::pose_confounded; zeros when not
  /// added), included in node_variance.
  Eigen::VectorXd node_pose;
  Eigen::VectorXd node_variance;  ///< #N: tr Σ_n, mm²
  double s2 = 0.0;                ///< prior scale (mN·mm)
  double vessel_alpha = 0.0;      ///< the vessel rows' compliance (mm/mN)
  double vessel_ratio = 0.0;      ///< the same ÷ median diag W
  double noise_sigma_mm = 0.0;    ///< implied per-row scatter of the vessel rows sqrt(s² α), mm
  index_t rows = 0;               ///< data rows used
  index_t exact_nodes = 0;        ///< nodes with an exact prior term (the rest interpolated)
  index_t solved_nodes = 0;  ///< of them, solved for (the others read from the compliance block)
  Eigen::VectorXd node_posterior;  ///< #N: deformable posterior trace without s² (mm/mN)
  Eigen::VectorXd node_rigid;      ///< #N: rigid term without s² (mm/mN)
  double s2_ml = 0.0;              ///< the candidate scales (mN·mm; 0 when not estimated)
  double s2_discrepancy = 0.0;
  double s2_restricted = 0.0;
  double s2_heldout = 0.0;
  index_t heldout_blocks = 0;  ///< vessel blocks behind s2_heldout
  /// The estimator s² came from (BY_POSE resolved; MAXIMUM_LIKELIHOOD when not estimated).
  UncertaintyOptions::ScaleEstimator scale_estimator =
      UncertaintyOptions::ScaleEstimator::MAXIMUM_LIKELIHOOD;
  /// The effective number of rows of s² (the held-out vessel blocks, else the rows) and the
  /// factor its upper confidence bound (UncertaintyOptions::scale_confidence) applied.
  double scale_rows = 0.0;
  double scale_factor = 1.0;
  index_t rigid_rank = 0;  ///< pose directions the rows determine (6 = all)
  /// #N: what the stated tracking accuracy adds to tr Σ_n (mm², not scaled by s²; included in
  /// node_variance), and the centre of its rotation (the rows' centroid, mm, model frame).
  Eigen::VectorXd node_tracking;
  Vector3d tracking_centre = Vector3d::Zero();
  std::string estimation;    ///< one line: how s² and α were estimated
  double seconds = 0.0;      ///< wall time
  double cpu_seconds = 0.0;  ///< process CPU time over the same span (all threads)
};

/// The name of the estimator s² came from (report.json's `s2_estimator`, bench's
/// `uncertainty_s2_estimator`): "maximum_likelihood", "held_out_blocks", "restricted" (held out
/// without a vessel block to hold out) or "discrepancy".
const char* scale_estimator_name(const UncertaintyResult& u);

/// Predicted error at every node of a registration result (uses r.positions, r.data_rows,
/// r.vessel_compliance_ratio and options.step's compliance ratios). Never throws on bad data:
/// non-finite intermediate values give the no-data answer with the reason in `estimation`.
UncertaintyResult predict_uncertainty(const RegistrationModel& model, const RegistrationResult& r,
                                      const RegistrationOptions& options,
                                      const UncertaintyOptions& uo);
/// The same with the options' own `uncertainty` group (the scene's).
UncertaintyResult predict_uncertainty(const RegistrationModel& model, const RegistrationResult& r,
                                      const RegistrationOptions& options);

/// What a stated tracking accuracy adds to tr Σ at points (#P×3, mm): a rigid error of the data's
/// frame, translation of RMS length σ_t = uo.tracking_translation_mm, rotation of RMS angle σ_r =
/// uo.tracking_rotation_deg about `centre`, both isotropic: σ_t² + (2/3) σ_r² |x − centre|²
/// (σ_r in rad), mm². Zeros when both are 0.
Eigen::VectorXd tracking_variance(ConstRef<MatrixX3d> points, const Vector3d& centre,
                                  const UncertaintyOptions& uo);

/// The confounded-pose term (UncertaintyOptions::pose_confounded) at every node, mm²: a pose
/// searched on the registered sweep and the sag it may have absorbed agree at the data and differ
/// by the pose's motion where the sag does not reach, so node n gets (|T⁻¹x − x| (1 − ρ_n))²
/// with T = r.start.transform, x the node's final position (model frame) and ρ_n its load
/// response (Frobenius norm of its 3×3 response to uniform loads) over the mean at the nodes of
/// the data rows `rows` (indices into r.data_rows), clipped to [0, 1]. Zeros without rows.
Eigen::VectorXd confounded_pose_variance(const RegistrationModel& model,
                                         const RegistrationResult& r,
                                         const std::vector<index_t>& rows);

/// sqrt of the barycentrically interpolated nodal variance at points (#P×3, model frame, mm);
/// points outside the mesh take the nearest tetrahedron (BarycentricMapping's rule).
Eigen::VectorXd sigma_at(const core::TetMesh& mesh, const Eigen::VectorXd& node_variance,
                         ConstRef<MatrixX3d> points);

}  // namespace brainshift::constraints
