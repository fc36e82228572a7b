#pragma once
/// @file
/// @brief Dense calibration of the predicted error: the predicted σ against the
/// actual error of the registered displacement at many points inside the brain, where the
/// phantom knows the truth everywhere (truth/displacement.nii.gz), instead of at its 14
/// landmarks only (a Spearman on 14 points has a standard error of ≈ 0.27).
///
/// Points: `count` voxel centres drawn uniformly (fixed seed) among the brain voxels of the
/// phantom's pre-operative labels (any label but background), mm, world RAS, pre-operative
/// frame. Their truth: X + u(X), u the truth field at the voxel, in the frame the phantom
/// writes its intra-operative landmarks in (case.json: the world, or the images' frame for the
/// offset cases: the tracking offset about the probe's face centre). Checked on the landmarks:
/// their X + u(X) there must reproduce the written positions within 0.5 mm RMS, else the dense
/// truth is left out (with a note).

#include "constraints/registration/registration.hpp"
#include "constraints/registration/uncertainty/uncertainty.hpp"
#include "imaging/evaluation/calibration.hpp"
#include "imaging/evaluation/metrics.hpp"

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace brainshift::workflow {

/// Points with known truth: where they were (pre-operative) and where they are (truth frame).
struct DenseTruth {
  MatrixX3d pre;                  ///< #P×3, mm, world RAS, pre-operative
  MatrixX3d intra;                ///< #P×3, mm, the frame of truth/landmarks_intraop.csv
  double frame_fit_rms_mm = 0.0;  ///< the check at the landmarks: RMS of truth − written, mm
  std::string note;               ///< why `pre` is empty, when it is
};

/// Samples the dense truth of a phantom folder (truth/displacement.nii.gz, preop/labels.nii.gz)
/// with its landmark pairs. Never throws on a missing or odd truth: an empty result with a note.
DenseTruth dense_truth(const std::filesystem::path& phantom, const imaging::LandmarkPairs& truth,
                       int count, std::uint32_t seed);

/// The predicted error against the actual one at a set of points.
struct DenseScore {
  imaging::UncertaintyCalibration cal;  ///< Spearman, within 1σ / 2σ, RMS ratio, means
  /// Mean predicted / actual error (mm) near (≤ 5 mm) and far (> 10 mm) from the Doppler points
  /// (distance from the truth position); NaN without such points.
  double near_predicted_mm = 0.0, far_predicted_mm = 0.0;
  double near_actual_mm = 0.0, far_actual_mm = 0.0;
  int near = 0, far = 0;
  double s2 = 0.0;  ///< the map's prior scale (mN·mm)
  /// Per point (for the dump): predicted σ (mm), its variance without s² and without the
  /// tracking prior (mm/mN), the tracking prior's variance (mm²), the actual error (mm), the
  /// distance to the nearest Doppler point (mm).
  std::vector<double> sigma, unscaled, tracking, actual, distance;
};

/// Scores the predicted error `u` of result `r` at `pre` (#P×3, rest frame) against `intra`
/// (#P×3, truth frame). \throws brainshift::Error on mismatched sizes.
DenseScore dense_score(const core::TetMesh& mesh, const constraints::UncertaintyResult& u,
                       const constraints::RegistrationResult& r, ConstRef<MatrixX3d> pre,
                       ConstRef<MatrixX3d> intra, ConstRef<MatrixX3d> vessel_points);

/// Writes the per-point values of `landmarks` and `dense` as CSV (kind, x, y, z, sigma_mm,
/// unscaled_var, tracking_var_mm2, actual_mm, distance_mm, s2, truth_shift_mm: |truth − X|, the
/// error without registration in the truth frame), atomically.
void write_dense_csv(const std::filesystem::path& path, const DenseScore* landmarks,
                     ConstRef<MatrixX3d> landmark_points, ConstRef<MatrixX3d> landmark_truth,
                     const DenseScore* dense, ConstRef<MatrixX3d> dense_points,
                     ConstRef<MatrixX3d> dense_truth);

}  // namespace brainshift::workflow
