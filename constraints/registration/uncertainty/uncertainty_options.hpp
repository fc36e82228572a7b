#pragma once
/// @file
/// @brief Options of the predicted-error model
/// (constraints/registration/uncertainty/uncertainty.hpp) and their table (core/option_fields.hpp):
/// the scene's group `uncertainty`.
///
/// The tracking prior: the intra-operative data come in the tracker's frame, and an
/// error of that frame (tracker, probe calibration) that every row shares is invisible to the
/// rows: the registration follows it and no residual shows it. Its stated accuracy is a rigid-pose
/// covariance added to Σ: a translation of RMS length `tracking_translation_mm` (isotropic) and a
/// rotation of RMS angle `tracking_rotation_deg` (isotropic) about the data rows' centroid c, so
/// at a point x the trace grows by σ_t² + (2/3) σ_r² |x − c|² (σ_r in rad; mm²): the map then
/// grows with the lever arm from the probe's data. Default 0 (not included): a site enters its
/// own system's figure (for orientation: a TRE-based QA of clinical trackers measured 1.6-2.0 mm
/// for infrared and 2.8-3.3 mm for electromagnetic ones, doi:10.1080/24699322.2023.2275522; tracked
/// ultrasound adds its probe calibration, typically 1-2 mm); the report states what was used.

#include "core/option_fields.hpp"

#include <string>

namespace brainshift::constraints {

struct UncertaintyOptions {
  /// Cell size (mm) of the grid that picks the coarse nodes of the exact prior term; 0 = every
  /// node exact.
  double coarse_spacing_mm = 20.0;
  /// Floor compliance of hard rows, × median diag W (dimensionless).
  double hard_row_ratio = 1e-3;
  /// A unilateral row whose value at the final state exceeds this (mm) is separated: not data.
  double separated_mm = 0.05;
  /// Without data rows s² cannot be estimated: the prior is scaled so that the median predicted
  /// error over the free nodes is this (mm), a brain shift of typical size.
  double no_data_median_mm = 10.0;
  /// Multiplies the estimated s² (dimensionless).
  double calibration = 1.0;
  /// How s² is estimated from the rows: DISCREPANCY (the fitted rows' residual against its
  /// expectation: the scatter the data show about the answer sets the scale), MAXIMUM_LIKELIHOOD
  /// (δ_free ~ N(0, s²(W + A)): the size of the shift sets it), HELD_OUT (the residuals at
  /// held-out vessel blocks, pose projected out: how well the fit predicts data it did not use),
  /// or BY_POSE (the default): MAXIMUM_LIKELIHOOD when the pose was searched on this sweep (or
  /// is the identity), HELD_OUT when it was given (StartResult::pose_given, a pre-dura sweep's).
  /// Why: a pose searched on the sweep it registers may have absorbed part of the sag, which no
  /// held-out block of the same field of view can show, and the size of what is left (ML) is the
  /// conservative scale. With a given pose δ_free holds the whole sag, the model's own load
  /// response rather than a draw of the isotropic prior, so ML measures the sag's size: on the
  /// 13 bench cases with a pre-dura pose it is 1.5-30 × the held-out scale and the map
  /// over-predicted the landmarks' error 1.4-9 ×, 3-4 × in the median (docs/BENCHMARKS.md, "The
  /// predicted error with a pre-dura pose").
  enum class ScaleEstimator { DISCREPANCY, MAXIMUM_LIKELIHOOD, HELD_OUT, BY_POSE };
  ScaleEstimator scale_estimator = ScaleEstimator::BY_POSE;
  /// The pose of the rigid start is an unknown with a flat prior (adds the rigid term).
  bool rigid_term = true;
  int solve_block = 192;  ///< right-hand sides per solve when computing the prior term
  /// s² is raised to this one-sided upper confidence bound of its sampling distribution: with k
  /// effectively independent rows, k ŝ²/s² ~ χ²(k), so s² ≤ k ŝ² / χ²_{1−c}(k) with confidence c;
  /// k = the vessel blocks held out (rows along one block are one piece of evidence of the scale),
  /// else the rows. 0: the point estimate ŝ². Few vessels (sparse_vessels: 6 blocks) widen the
  /// map more than many (standard: 21); docs/history/BENCHMARKS_NOTEBOOK.md "Predicted error".
  double scale_confidence = 0.95;
  /// The tracker's stated accuracy (see the file comment): RMS length of the translation error of
  /// the data's frame, mm (0: not included).
  double tracking_translation_mm = 0.0;
  /// RMS angle of the rotation error of the data's frame about the rows' centroid, degrees.
  double tracking_rotation_deg = 0.0;
  /// A pose searched on the sweep it registers (the global start, not a pose given by a pre-dura
  /// sweep) cannot tell a navigation offset from the part of the sag that looks like a shift and
  /// a tilt in the field of view; whatever part of its motion is sag moves the whole model with
  /// it. The two explanations agree where the data are and differ by the pose's motion where
  /// the sag does not reach: the pose's motion at each node, times one minus the node's load
  /// response relative to the data's (0 at the data, the whole motion at the fixed base), is
  /// added (predict_uncertainty()).
  /// Measured on the twelve phantom cases (docs/history/BENCHMARKS_NOTEBOOK.md, "Predicted error:
  /// the pose searched after opening").
  bool pose_confounded = true;
  [[nodiscard]] std::string validate() const;
};

/// The options' names, ranges and documentation: the scene's group `uncertainty`. The scale
/// estimator's confidence and the two pose terms' switches are constants of the method.
template <class V>
void visit_fields(UncertaintyOptions& o, V&& v) {
  v("coarse_spacing_mm", o.coarse_spacing_mm, core::Range{0, 1000},
    "cell size of the grid of nodes whose prior variance is solved exactly (mm; 0: every node)");
  v("calibration", o.calibration, core::Range{1e-6, 1e6},
    "multiplies the estimated prior scale s² (dimensionless)");
  v("tracking_translation_mm", o.tracking_translation_mm, core::Range{0, 100},
    "stated tracking accuracy: RMS translation error of the data's frame (mm; 0: not included)");
  v("tracking_rotation_deg", o.tracking_rotation_deg, core::Range{0, 45},
    "stated tracking accuracy: RMS rotation error of the data's frame about its centroid (deg)");
}

}  // namespace brainshift::constraints
