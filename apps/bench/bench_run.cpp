#include "apps/bench/bench_run.hpp"

#include "apps/workflow/intraop_frame.hpp"
#include "apps/workflow/model_folder.hpp"
#include "apps/workflow/prepare.hpp"
#include "constraints/registration/uncertainty/uncertainty.hpp"
#include "core/error.hpp"
#include "core/mapping/barycentric_mapping.hpp"
#include "core/timing.hpp"
#include "data_synth/cases/case_catalog.hpp"
#include "data_synth/cases/label_case.hpp"
#include "data_synth/cases/phantom_case.hpp"
#include "imaging/io/csv.hpp"

#include <chrono>
#include <cmath>
#include <ctime>
#include <fstream>
#include <sstream>
#include <thread>

#ifndef BRAINSHIFT_BUILD_TYPE
#define BRAINSHIFT_BUILD_TYPE "unknown"
#endif

namespace brainshift::workflow {
namespace {

using constraints::RegistrationOptions;
using constraints::RegistrationResult;
using core::Clock;
using core::seconds_since;
/// Dense calibration: points drawn uniformly among the brain voxels, fixed seed.
constexpr int kDensePoints = 500;
constexpr std::uint32_t kDenseSeed = 16;

/// The predicted error of one of our registrations at the case's landmarks (row.unc_*).
void score_uncertainty(BenchRow& row, const constraints::RegistrationModel& model,
                       const RegistrationResult& r, const CaseData& c,
                       const constraints::IntraopData& data, ConstRef<MatrixX3d> predicted) {
  RegistrationOptions o;
  o.uncertainty.tracking_translation_mm = c.tracking_spec_mm;
  o.uncertainty.tracking_rotation_deg = c.tracking_spec_deg;
  row.unc_tracking_mm = c.tracking_spec_mm;
  row.unc_tracking_deg = c.tracking_spec_deg;
  const constraints::UncertaintyResult u = constraints::predict_uncertainty(model, r, o);
  row.unc_s2 = u.s2;
  row.unc_s2_ml = u.s2_ml;
  row.unc_s2_restricted = u.s2_restricted;
  row.unc_s2_heldout = u.s2_heldout;
  row.unc_s2_estimator = constraints::scale_estimator_name(u);
  row.unc_rows = static_cast<double>(u.rows);
  row.unc_heldout_blocks = static_cast<double>(u.heldout_blocks);
  row.unc_landmark_points =
      dense_score(model.mesh(), u, r, c.truth.a, c.truth.b, data.vessel_points);
  if (c.dense.pre.rows() > 0)
    row.unc_dense = dense_score(model.mesh(), u, r, c.dense.pre, c.dense.intra, data.vessel_points);
  row.unc_s = u.seconds;
  row.unc_cpu_s = u.cpu_seconds;
  std::vector<double> free;
  for (index_t i = 0; i < model.mesh().num_nodes(); ++i)
    if (!model.mechanics().dofs().is_fixed_node(i)) free.push_back(u.node_sigma_mm[i]);
  row.unc_median_mm = imaging::percentile(free, 50.0);
  const Eigen::VectorXd at = constraints::sigma_at(model.mesh(), u.node_variance, c.truth.a);
  const std::vector<double> sigma(at.data(), at.data() + at.size());
  row.unc_calibration =
      imaging::calibrate_uncertainty(sigma, imaging::landmark_errors(predicted, c.truth.b));
  row.unc_landmarks_mm = row.unc_calibration->mean_predicted_mm;
  double near = 0, far = 0;
  int n_near = 0, n_far = 0;
  for (Eigen::Index i = 0; i < c.truth.b.rows() && data.vessel_points.rows() > 0; ++i) {
    const double d = (data.vessel_points.rowwise() - c.truth.b.row(i)).rowwise().norm().minCoeff();
    if (d <= 5.0) near += at[i], ++n_near;
    if (d > 10.0) far += at[i], ++n_far;
  }
  if (n_near) row.unc_near_mm = near / n_near;
  if (n_far) row.unc_far_mm = far / n_far;
}

}  // namespace

void reset_peak_rss() { std::ofstream("/proc/self/clear_refs") << "5"; }

double status_mib(const std::string& key) {
  std::ifstream in("/proc/self/status");
  for (std::string line; std::getline(in, line);)
    if (line.rfind(key, 0) == 0) return std::stod(line.substr(key.size())) / 1024.0;
  return 0.0;
}

nlohmann::json machine() {
  std::string cpu = "unknown";
  {
    std::ifstream in("/proc/cpuinfo");
    for (std::string line; std::getline(in, line);)
      if (line.rfind("model name", 0) == 0) {
        cpu = line.substr(line.find(':') + 2);
        break;
      }
  }
  double mem_gib = 0;
  {
    std::ifstream in("/proc/meminfo");
    std::string key;
    double kb = 0;
    if (in >> key >> kb) mem_gib = kb / (1024.0 * 1024.0);
  }
  const std::time_t now = std::time(nullptr);
  char date[32];
  std::strftime(date, sizeof date, "%Y-%m-%d %H:%M UTC", std::gmtime(&now));
  return {{"cpu", cpu},
          {"hardware_threads", std::thread::hardware_concurrency()},
          {"memory_gib", std::round(mem_gib * 10) / 10},
          {"build_type", BRAINSHIFT_BUILD_TYPE},
          {"date", date}};
}

const std::vector<std::string>& real_anatomy_cases() {
  static const std::vector<std::string> names = {"icbm_standard", "icbm_offset_20mm"};
  return names;
}
bool is_real_anatomy_case(const std::string& name) { return name.rfind("icbm_", 0) == 0; }
std::filesystem::path icbm_labels(const std::filesystem::path& real_data) {
  return real_data / "icbm152" / "labels.nii.gz";
}

CaseData make_case(const std::string& name, std::uint32_t seed, const std::filesystem::path& dir,
                   const std::filesystem::path& real_data) {
  std::filesystem::create_directories(dir.parent_path());
  data_synth::CaseOptions co;
  co.out = dir;
  if (is_real_anatomy_case(name)) {
    data_synth::LabelCaseRequest r;
    r.labels = icbm_labels(real_data);
    r.case_name = name.substr(5);
    r.seed = seed;
    (void)data_synth::generate_label_case(r, co);
  } else {
    (void)data_synth::generate_case(name, seed, co);
  }
  CaseData c;
  c.name = name;
  c.phantom = dir;
  const imaging::Landmarks pre = imaging::read_landmarks(dir / "truth/landmarks_preop.csv");
  const imaging::Landmarks intra = imaging::read_landmarks(dir / "truth/landmarks_intraop.csv");
  c.truth = imaging::match_landmarks_by_id(pre.ids, pre.points, intra.ids, intra.points);
  BS_VERIFY(!c.truth.ids.empty(), dir.string() << ": the phantom has no landmarks in common");
  // The declared tracking spec: the recipe's (the ICBM152 cases take the named case's).
  const data_synth::CaseParameters p =
      data_synth::named_case(is_real_anatomy_case(name) ? name.substr(5) : name, seed);
  c.tracking_spec_mm = p.tracking_spec_translation_mm;
  c.tracking_spec_deg = p.tracking_spec_rotation_deg;
  c.dense = dense_truth(dir, c.truth, kDensePoints, kDenseSeed);
  return c;
}

double prepare_case(const CaseData& c, const std::filesystem::path& model, double refinement) {
  const auto t0 = Clock::now();
  PrepareOptions pa;
  pa.labels = c.phantom / "preop/labels.nii.gz";
  pa.mra = c.phantom / "preop/mra.nii.gz";
  pa.mesh_refinement = refinement;
  pa.out = model;
  (void)prepare_model(pa, Progress("prepare"));
  return seconds_since(t0);
}

MatrixX3d doppler_points(const Session& s, const CaseData& c, double step_mm) {
  imaging::VesselExtractionOptions o;
  o.resample_step_mm = step_mm;
  return read_intraop(s, c.phantom / "intraop/doppler.nii.gz", std::nullopt, o).data.vessel_points;
}
void score(BenchRow& row, const constraints::RegistrationModel& model, const RegistrationResult& r,
           const CaseData& c, const constraints::IntraopData& data) {
  row.iterations = r.iterations;
  row.converged = r.converged;
  row.stop = constraints::to_string(r.stop);
  row.stop_reason = r.stop_reason;
  row.rows = r.history.empty() ? 0 : r.history.back().rows;
  row.t = r.seconds;
  row.max_displacement_mm =
      r.displacement.rows() ? r.displacement.rowwise().norm().maxCoeff() : 0.0;
  row.fixed_base_moved_mm = fixed_base_motion(r, model).mean_mm;
  core::MappingOptions mo;
  mo.max_outside_distance = 20.0;
  const core::BarycentricMapping map(model.mesh(), c.truth.a, mo);
  const MatrixX3d predicted = to_intraop_frame(r, map.apply(r.positions));
  const auto before = imaging::error_stats(imaging::landmark_errors(c.truth.a, c.truth.b));
  const auto after = imaging::error_stats(imaging::landmark_errors(predicted, c.truth.b));
  row.tre_before_mean = before.mean;
  row.tre_before_p95 = before.p95;
  row.tre_mean = after.mean;
  row.tre_p95 = after.p95;
  row.tre_max = after.max;
  row.corrected_pct = imaging::percent_shift_corrected(before.mean, after.mean);
  // Distance from an intra-operative position to the nearest vessel point of the sweep (mm).
  const auto to_vessels = [&](const auto& p) {
    return (data.vessel_points.rowwise() - p).rowwise().norm().minCoeff();
  };
  {
    const std::vector<double> err = imaging::landmark_errors(predicted, c.truth.b);
    double near = 0, far = 0;
    row.landmarks_near = row.landmarks_far = 0;
    for (Eigen::Index i = 0; i < c.truth.b.rows() && data.vessel_points.rows() > 0; ++i) {
      const double d = to_vessels(c.truth.b.row(i));
      if (d <= 5.0) near += err[static_cast<std::size_t>(i)], ++row.landmarks_near;
      if (d > 10.0) far += err[static_cast<std::size_t>(i)], ++row.landmarks_far;
    }
    row.tre_near_mean =
        row.landmarks_near ? near / static_cast<double>(row.landmarks_near) : std::nan("");
    row.tre_far_mean =
        row.landmarks_far ? far / static_cast<double>(row.landmarks_far) : std::nan("");
  }
  if (c.dense.pre.rows() > 0) {
    const core::BarycentricMapping dense_map(model.mesh(), c.dense.pre, mo);
    const MatrixX3d mapped = to_intraop_frame(r, dense_map.apply(r.positions));
    const std::vector<double> after_mm = imaging::landmark_errors(mapped, c.dense.intra);
    const std::vector<double> before_mm = imaging::landmark_errors(c.dense.pre, c.dense.intra);
    row.dense_error_mean = imaging::error_stats(after_mm).mean;
    row.dense_before_mean = imaging::error_stats(before_mm).mean;
    double deep_after = 0.0, deep_before = 0.0;
    index_t n = 0;
    for (Eigen::Index i = 0; i < c.dense.intra.rows() && data.vessel_points.rows() > 0; ++i) {
      if (to_vessels(c.dense.intra.row(i)) <= kDeepFromVesselsMm) continue;
      deep_after += after_mm[static_cast<std::size_t>(i)];
      deep_before += before_mm[static_cast<std::size_t>(i)];
      ++n;
    }
    row.dense_deep_points = n;
    if (n > 0) {
      row.dense_deep_error_mean = deep_after / static_cast<double>(n);
      row.dense_deep_before_mean = deep_before / static_cast<double>(n);
    }
  }
  if (!r.data_rows.empty() && row.method != "prescribed_displacement")
    score_uncertainty(row, model, r, c, data, predicted);
  if (row.corrected_pct) *row.corrected_pct += 0.0;  // no "-0.0" in the tables
  row.ok = r.positions.allFinite() && std::isfinite(after.mean);
  if (!row.ok) row.error = "non-finite result";
}

void describe(BenchRow& row, const Session& s, const constraints::IntraopData& data) {
  row.nodes = s.model->mesh().num_nodes();
  row.tets = s.model->mesh().num_tets();
  row.surface_vertices = static_cast<index_t>(s.model->surface().vertices.rows());
  row.skeleton_points = static_cast<index_t>(s.model->skeleton().points.rows());
  row.vessel_points = static_cast<index_t>(data.vessel_points.rows());
  row.footprint_points = static_cast<index_t>(data.footprint_points.rows());
  row.setup_s = s.seconds_load;
}

RegistrationOptions product_options(const Session& s) {
  RegistrationOptions o = s.loaded.scene.options;
  o.use_footprint = false;
  return o;
}

}  // namespace brainshift::workflow
