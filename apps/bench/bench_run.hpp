#pragma once
/// @file
/// @brief The pieces of one benchmark run (bench.hpp): a row of results, the phantom case it runs
/// on, the memory and machine it records, and how a result is scored against the case's
/// landmarks (TRE in mm, intra-operative frame, world RAS).

#include "apps/bench/bench_dense.hpp"
#include "apps/workflow/progress.hpp"
#include "apps/workflow/session.hpp"
#include "constraints/registration/registration.hpp"
#include "imaging/evaluation/calibration.hpp"
#include "imaging/evaluation/metrics.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace brainshift::workflow {

/// Mesh refinements whose node counts are ≈ 1k, 2k, 5k, 10k, 20k, 50k on the phantom (measured:
/// nodes ≈ 1,600 r^2.7, not r³, as the boundary and the tumour keep their own sizing).
inline constexpr double bench_refinements[] = {0.85, 1.1, 1.6, 2.1, 2.75, 3.9};

/// The "deep" dense points: farther than this from every intra-operative vessel point (mm). The
/// cases' probe images 60 mm below its face (data_synth's ProbeOptions::depth), so a point this far
/// from every vessel the sweep saw is one no data reach.
inline constexpr double kDeepFromVesselsMm = 60.0;

/// One benchmark run: a row of results.csv.
struct BenchRow {
  std::string suite;  ///< cases | sweeps
  std::string case_name;
  std::uint32_t seed = 0;
  std::string sweep;   ///< for suite sweeps: mesh_size, vessel_sampling, compliance, pgs_tolerance,
                       ///< constraint_sets
  std::string value;   ///< the swept setting
  std::string method;  ///< constraint_icp | rigid_only | prescribed_displacement; full runs also
                       ///< block_cv | block_cv_1se | block_cv_paired |
                       ///< gcv_compliance | dura_sliding | dura_unilateral
                       ///< (variants of ours)
  index_t nodes = 0, tets = 0, surface_vertices = 0, skeleton_points = 0, vessel_points = 0,
          footprint_points = 0;
  index_t rows = 0;
  int iterations = 0;
  bool converged = false;
  std::string stop;
  std::string stop_reason;  ///< the registration's own account of its stop
  double prepare_s =
      0.0;               ///< pre-operative: the whole `prepare` (meshing, factor, compliance block)
  double setup_s = 0.0;  ///< intra-operative model set-up: load MODEL, factorise, adopt the block
  constraints::StageTimes t;
  double rss_before_mib =
      0.0;  ///< resident memory when the run started (what the process already held)
  double peak_rss_mib = 0.0;  ///< high-water mark during the run, including rss_before_mib
  double tre_before_mean = 0.0, tre_before_p95 = 0.0;
  double tre_mean = 0.0, tre_p95 = 0.0, tre_max = 0.0;
  /// Mean TRE over the landmarks near (≤ 5 mm) and far (> 10 mm) from the intra-operative vessel
  /// points (distance from the landmark's intra-operative position to the nearest Doppler point):
  /// where the data constrain the answer, and where only the mechanics can. NaN without any.
  double tre_near_mean = 0.0, tre_far_mean = 0.0;
  index_t landmarks_near = 0, landmarks_far = 0;
  std::optional<double> corrected_pct;
  /// Mean error over the case's dense truth points (bench_dense.hpp: 500 points drawn uniformly
  /// in the brain, their truth from the phantom's truth field), for every method: the whole
  /// brain, where landmarks near the probe cannot look. Unset without a dense truth.
  std::optional<double> dense_error_mean;
  /// The same points' mean error with no registration (pre-operative position against the
  /// truth's intra-operative one, mm): the whole-brain figure a registration must beat.
  std::optional<double> dense_before_mean;
  /// The same two over the dense points deeper than kDeepFromVesselsMm from every
  /// intra-operative vessel point (the distance as for tre_far_mean), where no data reach and
  /// only the mechanics carries the answer; unset without a dense truth or vessel points.
  std::optional<double> dense_deep_error_mean, dense_deep_before_mean;
  index_t dense_deep_points = 0;
  double max_displacement_mm = 0.0;
  /// Mean motion of the model's fixed base by the answer's rigid part (workflow::
  /// fixed_base_motion(), mm): on a case without a navigation offset all of it is error; on the
  /// offset cases the true pose moves the base too.
  double fixed_base_moved_mm = 0.0;
  bool ok = false;  ///< finite answer, no exception
  std::string error;
  std::string note;  ///< e.g. why the B-mode gave no footprint
  /// Predicted error (runs of ours only, else unset): its cost, the median over the
  /// free nodes, the mean at the landmarks (all, near, far as above) and its calibration against
  /// the landmarks' actual errors (imaging/evaluation/calibration.hpp).
  std::optional<double> unc_s, unc_cpu_s, unc_median_mm, unc_landmarks_mm, unc_near_mm, unc_far_mm;
  std::optional<imaging::UncertaintyCalibration> unc_calibration;
  /// The map's prior scale and its candidates (mN·mm), and the data rows it used.
  std::optional<double> unc_s2, unc_s2_ml, unc_s2_restricted, unc_s2_heldout, unc_rows,
      unc_heldout_blocks;
  std::string unc_s2_estimator;  ///< which candidate s² is (scale_estimator_name(); empty: none)
  /// The tracking prior the run used (the case's declared spec; uncertainty.tracking_*).
  double unc_tracking_mm = 0.0, unc_tracking_deg = 0.0;
  /// Dense calibration (bench_dense.hpp) at the case's dense points, and the same per-point
  /// values at its landmarks (for the dump).
  std::optional<DenseScore> unc_dense, unc_landmark_points;
};

/// The data of one case: a phantom folder and its landmarks.
struct CaseData {
  std::string name;
  std::filesystem::path phantom;
  imaging::LandmarkPairs truth;  ///< a: pre-operative, b: intra-operative landmarks
  DenseTruth dense;              ///< points with known truth inside the brain (dense calibration)
  /// The tracking accuracy the case declares (data_synth CaseParameters::tracking_spec_*: RMS
  /// mm, deg): passed to the predicted error's tracking prior.
  double tracking_spec_mm = 0.0, tracking_spec_deg = 0.0;
};

/// The cases on real anatomy (ICBM152): the named recipe after the prefix on the brain
/// of REAL_DATA/icbm152/labels.nii.gz, default craniotomy and tumour.
const std::vector<std::string>& real_anatomy_cases();
bool is_real_anatomy_case(const std::string& name);
/// REAL_DATA/icbm152/labels.nii.gz.
std::filesystem::path icbm_labels(const std::filesystem::path& real_data);

/// Generates the phantom `name` (seed) into `dir` and reads its landmarks.
/// \throws brainshift::Error when the phantom has no landmarks in common.
CaseData make_case(const std::string& name, std::uint32_t seed, const std::filesystem::path& dir,
                   const std::filesystem::path& real_data);

/// Runs `prepare` on a phantom into `model` (mesh refinement as prepare's --refine); returns its
/// wall time, s.
double prepare_case(const CaseData& c, const std::filesystem::path& model, double refinement);

/// Vessel points from the case's Doppler, resampled every `step_mm` along the centrelines,
/// through `register`'s own reader (same checks: overlap with the model, NaN, no vessels).
MatrixX3d doppler_points(const Session& s, const CaseData& c, double step_mm);

/// The machine, build type and date (results.json → machine).
nlohmann::json machine();
/// Resets the kernel's peak-RSS counter of this process (Linux ≥ 4.0), so VmHWM measures one run.
void reset_peak_rss();
/// A "VmHWM:" / "VmRSS:" field of /proc/self/status, MiB (0 when unavailable).
double status_mib(const std::string& key);

/// Runs `reg` (one registration; deterministic for a given model and data) `repeat` times and
/// returns the run whose total time is the median, so its stage times are one consistent run.
template <typename F>
constraints::RegistrationResult median_of(int repeat, F&& reg) {
  std::vector<constraints::RegistrationResult> runs;
  for (int i = 0; i < std::max(1, repeat); ++i) runs.push_back(reg());
  std::sort(runs.begin(), runs.end(),
            [](const constraints::RegistrationResult& a, const constraints::RegistrationResult& b) {
              return a.seconds.total < b.seconds.total;
            });
  return std::move(runs[runs.size() / 2]);
}

/// TRE of a result against the case's landmarks: a pre-operative landmark X is predicted at
/// T⁻¹ (X + u(X)), u interpolated in its tetrahedron (landmarks up to 20 mm outside the mesh are
/// projected onto it; none are on the phantoms, which landmark the brain).
void score(BenchRow& row, const constraints::RegistrationModel& model,
           const constraints::RegistrationResult& r, const CaseData& c,
           const constraints::IntraopData& data);

/// Runs `f` (which fills the row) with the peak memory measured and any error recorded.
template <typename F>
BenchRow measured(BenchRow row, const Progress& progress, F&& f) {
  progress.stage(row.case_name + " " +
                 (row.sweep.empty() ? row.method : row.sweep + "=" + row.value));
  reset_peak_rss();
  row.rss_before_mib = status_mib("VmRSS:");
  try {
    f(row);
  } catch (const std::exception& e) {
    row.ok = false;
    row.error = e.what();
  }
  row.peak_rss_mib = status_mib("VmHWM:");
  return row;
}

/// The row's model and data sizes and the model's set-up time.
void describe(BenchRow& row, const Session& s, const constraints::IntraopData& data);

/// The product's defaults for the benchmark: the scene's options, vessels only (as the demo:
/// the footprint rows currently cost accuracy on the phantoms; the constraint-set sweep shows it).
constraints::RegistrationOptions product_options(const Session& s);

}  // namespace brainshift::workflow
