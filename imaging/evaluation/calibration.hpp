#pragma once
/// @file
/// @brief Calibration of a predicted-error map against true errors: Spearman rank
/// correlation and the share of landmarks within 1 and 2 predicted sigma.
///
/// Convention: the predicted error σ at a point is the RMS length of the 3-D error vector,
/// sqrt(tr Σ) (mm; what RES/uncertainty.nii.gz holds). A landmark is "within k sigma" when its
/// actual error |e| ≤ k σ. For a calibrated isotropic 3-D Gaussian, |e| / (σ/√3) follows the
/// chi distribution with 3 degrees of freedom, so the expected shares are
/// P(χ²₃ ≤ 3) = 60.8 % within 1 sigma and P(χ²₃ ≤ 12) = 99.3 % within 2 sigma.

#include "core/config.hpp"

#include <utility>
#include <vector>

namespace brainshift::imaging {

/// Expected shares (%) within 1 and 2 sigma for a calibrated isotropic 3-D Gaussian (above).
inline constexpr double expected_within_1_sigma_pct = 60.84;
inline constexpr double expected_within_2_sigma_pct = 99.26;
/// Per-axis convention: each component of the error vector against σ/√3 (the per-axis standard
/// deviation of an isotropic Gaussian of RMS length σ); calibrated: 68.27 % and 95.45 %.
inline constexpr double expected_per_axis_within_1_sigma_pct = 68.27;
inline constexpr double expected_per_axis_within_2_sigma_pct = 95.45;

struct UncertaintyCalibration {
  int count = 0;          ///< landmarks compared
  double spearman = 0.0;  ///< rank correlation predicted vs actual error (0 when undefined)
  double within_1_sigma_pct = 0.0;
  double within_2_sigma_pct = 0.0;
  double mean_predicted_mm = 0.0;
  double mean_actual_mm = 0.0;
  /// RMS of actual / predicted (≈ 1 when calibrated; > 1: the map is over-confident).
  double rms_ratio = 0.0;
};

/// Spearman rank correlation of two equally long samples (average ranks for ties); 0 when
/// fewer than 2 values or a sample is constant. \throws brainshift::Error on different sizes.
double spearman(const std::vector<double>& a, const std::vector<double>& b);

/// Shares (%) of the error components (#P×3, mm) within 1 and 2 × σ_p/√3 (σ_p = predicted_mm[p],
/// the per-axis convention above), over the 3P components: {within 1, within 2}.
/// \throws brainshift::Error on different sizes or non-finite / negative values.
std::pair<double, double> per_axis_within_sigma_pct(const std::vector<double>& predicted_mm,
                                                    ConstRef<MatrixX3d> error_mm);

/// Calibration of predicted errors (mm, ≥ 0) against actual errors (mm).
/// \throws brainshift::Error on different sizes or non-finite / negative values.
UncertaintyCalibration calibrate_uncertainty(const std::vector<double>& predicted_mm,
                                             const std::vector<double>& actual_mm);

}  // namespace brainshift::imaging
