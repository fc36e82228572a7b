#pragma once
/// @file
/// @brief The data term's noise model: the compliance of the vessel rows chosen from the data by
/// generalised cross-validation (GCV; Golub, Heath & Wahba 1979).
///
/// Doppler centrelines scatter by millimetres about the true vessels. A vessel row with
/// compliance ε obeys g + ε λ = 0, which is the MAP estimate of the linear-Gaussian model
///   δ_free = H u + e,   u ~ N(0, τ C),   e ~ N(0, σ² I),   ε = σ² / τ,
/// where δ_free (mm) is what the rows would be violated by if the model relaxed to its unloaded
/// shape, C the model's compliance and W = H C Hᵀ (mm/mN) the Delassus operator. At a converged
/// state (rows linearised there, pairs right) the fitted row residual is
///   r(ε) = ε (W + ε I)⁻¹ δ_free,     and the influence matrix is A(ε) = W (W + ε I)⁻¹.
/// GCV picks the ε that minimises the leave-one-out prediction error of the rows,
///   GCV(ε) = m ‖r(ε)‖² / tr(I − A(ε))²,
/// from one eigendecomposition of W: no constant tuned to a data set, only the scatter the paired
/// points show against what the mechanics can explain. Exact rows (ε → 0) chase the noise;
/// ε → ∞ leaves the model where the rigid start put it. The noise level σ̂² = ‖r‖² / tr(I − A) is
/// the measured scatter of the paired points (mm), reported and used to refuse data too
/// scattered to trust.

#include <string>
#include <vector>

#include "core/config.hpp"

namespace brainshift::constraints {

struct NoiseOptions {
  /// Run the SMOOTH stage at the GCV compliance. Off by default: on the phantoms GCV reads the
  /// Doppler centrelines' errors as signal (they are correlated along each vessel, not white),
  /// picks the stiffest ratio of its range, and the smoothing stage rarely settles; a stiffer
  /// data term is then worse, not better (docs/BENCHMARKS.md, "Noise model"). The estimate itself
  /// (the scatter) is always computed and reported, and used to refuse too scattered data.
  bool enabled = false;
  /// Search range of the ratio ε / median(diag W) (dimensionless, as StepOptions::compliance_ratio).
  double min_ratio = 0.02;
  double max_ratio = 1000.0;
  int grid = 64;  ///< log-spaced candidates in [min_ratio, max_ratio]
  /// A smoothing stage runs only when the chosen ratio differs from the one in use by more than
  /// this factor (either way): below it the change is within GCV's own resolution.
  double change_factor = 1.5;
  int max_iterations = 40;  ///< iteration cap of the smoothing stage
  /// Largest Delassus block decomposed (rows); beyond it every k-th point's rows are used.
  int max_rows = 1200;
  [[nodiscard]] std::string validate() const;
};

/// What the noise model found.
struct NoiseEstimate {
  bool valid = false;        ///< false: too few rows or a degenerate W; `ratio` is then unchanged
  double ratio = 0.0;        ///< chosen compliance ratio of the vessel rows
  double sigma_mm = 0.0;     ///< estimated scatter of the paired points about the model, per row (mm)
  double effective_dof = 0.0;  ///< tr A: how many of the rows' degrees of freedom the fit follows
  index_t rows = 0;          ///< vessel rows used
  std::string message;       ///< one line
};

/// GCV choice of the vessel-row compliance.
/// @param[in] W Delassus operator of all rows of a step, without row compliance (mm/mN).
/// @param[in] delta_free δ + H dx_free of those rows (mm).
/// @param[in] vessel_rows indices of the vessel rows in W (pairs of a sliding line adjacent).
/// @param[in] scale median(diag W) over all rows: the unit of the ratio (mN⁻¹·mm).
/// @param[in] current_ratio returned (valid = false) when there is nothing to decide on.
NoiseEstimate estimate_vessel_noise(const Eigen::MatrixXd& W, const Eigen::VectorXd& delta_free,
                                    const std::vector<index_t>& vessel_rows, double scale, double current_ratio,
                                    const NoiseOptions& options);

}  // namespace brainshift::constraints
