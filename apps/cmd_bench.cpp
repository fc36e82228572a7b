#include "cmd_bench.hpp"

#include "cmd_prepare.hpp"
#include "cmd_register.hpp"
#include "intraop_footprint.hpp"
#include "model_folder.hpp"
#include "progress.hpp"

#include "constraints/registration/registration.hpp"
#include "constraints/registration/uncertainty.hpp"
#include "core/error.hpp"
#include "core/mapping/barycentric_mapping.hpp"
#include "core/timing.hpp"
#include "data_synth/cases/case_catalog.hpp"
#include "data_synth/cases/label_case.hpp"
#include "data_synth/cases/phantom_case.hpp"
#include "imaging/evaluation/calibration.hpp"
#include "imaging/evaluation/metrics.hpp"
#include "imaging/io/atomic_write.hpp"
#include "imaging/io/csv.hpp"
#include "imaging/vessels/vessel_extraction.hpp"

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <ctime>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <optional>
#include <ostream>
#include <sstream>
#include <thread>

#ifndef BRAINSHIFT_BUILD_TYPE
#define BRAINSHIFT_BUILD_TYPE "unknown"
#endif

namespace brainshift::apps {
namespace {

using core::Clock;
constexpr auto since = &core::seconds_since;  // core/timing.hpp
using constraints::ConstraintSet;
using constraints::RegistrationOptions;
using constraints::RegistrationResult;

/// Mesh refinements whose node counts are ≈ 1k, 2k, 5k, 10k, 20k, 50k on the phantom (measured:
/// nodes ≈ 1,600 r^2.7, not r³, as the boundary and the tumour keep their own sizing).
constexpr double refinements[] = {0.85, 1.1, 1.6, 2.1, 2.75, 3.9};

/// One benchmark run: a row of results.csv.
struct Row {
  std::string suite;  ///< cases | sweeps
  std::string case_name;
  std::uint32_t seed = 0;
  std::string sweep;   ///< for suite sweeps: mesh_size, vessel_sampling, compliance, pgs_tolerance,
                       ///< constraint_sets
  std::string value;   ///< the swept setting
  std::string method;  ///< constraint_icp | rigid_only | prescribed_displacement; full runs also
                       ///< block_cv | gcv_compliance | dura_sliding | dura_unilateral
                       ///< (variants of ours)
  index_t nodes = 0, tets = 0, surface_vertices = 0, skeleton_points = 0, vessel_points = 0,
          footprint_points = 0;
  index_t rows = 0;
  int iterations = 0;
  bool converged = false;
  std::string stop;
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
  double max_displacement_mm = 0.0;
  bool ok = false;  ///< finite answer, no exception
  std::string error;
  std::string note;  ///< e.g. why the B-mode gave no footprint
  /// Predicted error (issue 16; runs of ours only, else unset): its cost, the median over the
  /// free nodes, the mean at the landmarks (all, near, far as above) and its calibration against
  /// the landmarks' actual errors (imaging/evaluation/calibration.hpp).
  std::optional<double> unc_s, unc_median_mm, unc_landmarks_mm, unc_near_mm, unc_far_mm;
  std::optional<imaging::UncertaintyCalibration> unc_calibration;
};

// --- machine and memory -------------------------------------------------------------------

/// Resets the kernel's peak-RSS counter of this process (Linux ≥ 4.0), so VmHWM measures one run.
void reset_peak_rss() { std::ofstream("/proc/self/clear_refs") << "5"; }

/// A "VmHWM:" / "VmRSS:" field of /proc/self/status, MiB (0 when unavailable).
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

// --- the data of one case -------------------------------------------------------------------

struct CaseData {
  std::string name;
  std::filesystem::path phantom;
  imaging::LandmarkPairs truth;  ///< a: pre-operative, b: intra-operative landmarks
};

/// The cases on real anatomy (ICBM152, issue 18): the named recipe after the prefix on the brain
/// of REAL_DATA/icbm152/labels.nii.gz, default craniotomy and tumour.
const std::vector<std::string> real_anatomy_cases = {"icbm_standard", "icbm_offset_20mm"};
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
  CaseData c{name, dir, {}};
  const imaging::Landmarks pre = imaging::read_landmarks(dir / "truth/landmarks_preop.csv");
  const imaging::Landmarks intra = imaging::read_landmarks(dir / "truth/landmarks_intraop.csv");
  c.truth = imaging::match_landmarks_by_id(pre.ids, pre.points, intra.ids, intra.points);
  BS_VERIFY(!c.truth.ids.empty(), dir.string() << ": the phantom has no landmarks in common");
  return c;
}

/// Runs `prepare` on a phantom; returns its wall time.
double prepare(const CaseData& c, const std::filesystem::path& model, double refinement) {
  const auto t0 = Clock::now();
  PrepareArgs pa;
  pa.labels = c.phantom / "preop/labels.nii.gz";
  pa.mra = c.phantom / "preop/mra.nii.gz";
  pa.mesh_refinement = refinement;
  pa.out = model;
  std::ostringstream quiet;
  run_prepare(pa, quiet);
  return since(t0);
}

/// Vessel points from the case's Doppler, resampled every `step_mm` along the centrelines,
/// through `register`'s own reader (same checks: overlap with the model, NaN, no vessels).
MatrixX3d doppler_points(const Session& s, const CaseData& c, double step_mm) {
  imaging::VesselExtractionOptions o;
  o.resample_step_mm = step_mm;
  return read_intraop(s, c.phantom / "intraop/doppler.nii.gz", std::nullopt, o).data.vessel_points;
}

// --- methods --------------------------------------------------------------------------------

/// The rigid start alone: no deformation.
RegistrationResult rigid_only(constraints::RegistrationModel& model,
                              const constraints::IntraopData& data,
                              const RegistrationOptions& options) {
  const auto t0 = Clock::now();
  RegistrationResult r;
  r.rigid = constraints::rigid_start(model, data, options);
  r.positions = model.mesh().nodes();
  r.displacement = MatrixX3d::Zero(r.positions.rows(), 3);
  r.converged = true;
  r.stop = constraints::RegistrationStop::CONVERGED;
  r.stop_reason = "rigid only";
  r.seconds.rigid = r.seconds.total = since(t0);
  return r;
}

/// The seeds' approach (prescribed displacements, a forward model): after the same rigid start,
/// each vessel point is assigned once to its nearest pre-operative skeleton point (within the
/// pairing distance); each skeleton point so chosen is displaced onto the mean of its points by
/// point-to-point rows (as soft as our vessel rows), and the corotational model is solved with
/// these displacements. No sliding along the vessels and no re-pairing.
RegistrationResult prescribed_displacement(constraints::RegistrationModel& model,
                                           const constraints::IntraopData& data,
                                           const RegistrationOptions& options) {
  const auto t0 = Clock::now();
  const constraints::RigidInitResult rigid = options.start == constraints::RigidStart::RIGID
                                                 ? constraints::rigid_start(model, data, options)
                                                 : constraints::RigidInitResult{};
  const double t_rigid = since(t0);
  const MatrixX3d& S = model.skeleton().points;
  std::map<index_t, std::pair<Vector3d, int>> sum;  // skeleton point → (Σ targets, count)
  for (Eigen::Index i = 0; i < data.vessel_points.rows(); ++i) {
    const Vector3d q = rigid.transform * Vector3d(data.vessel_points.row(i).transpose());
    Eigen::Index best = -1;
    const double d2 =
        S.rows() ? (S.rowwise() - q.transpose()).rowwise().squaredNorm().minCoeff(&best) : 0.0;
    if (best < 0 || std::sqrt(d2) > options.pair_max_distance_mm) continue;
    auto& [s, n] = sum.try_emplace(static_cast<index_t>(best), Vector3d::Zero(), 0).first->second;
    s += q;
    ++n;
  }
  constraints::IntraopData d;
  d.landmark_model_points.resize(static_cast<Eigen::Index>(sum.size()), 3);
  d.landmark_targets.resize(static_cast<Eigen::Index>(sum.size()), 3);
  Eigen::Index k = 0;
  for (const auto& [p, acc] : sum) {
    d.landmark_model_points.row(k) = S.row(p);
    d.landmark_targets.row(k++) = (acc.first / acc.second).transpose();
  }
  RegistrationOptions o = options;
  o.start = constraints::RigidStart::IDENTITY;
  o.use_vessels = o.use_footprint = false;
  o.use_landmarks = true;
  o.dura.mode = constraints::DuraOptions::Mode::NONE;
  const auto vessels = static_cast<std::size_t>(ConstraintSet::VESSELS);
  o.step.compliance_ratio[static_cast<std::size_t>(ConstraintSet::LANDMARK)] =
      o.step.compliance_ratio[vessels];
  RegistrationResult r = constraints::register_model(model, d, o);
  r.rigid = rigid;
  r.seconds.rigid = t_rigid;
  r.seconds.total = since(t0);
  return r;
}

/// Runs `reg` (one registration; deterministic for a given model and data) `repeat` times and
/// returns the run whose total time is the median, so its stage times are one consistent run.
template <typename F>
RegistrationResult median_of(int repeat, F&& reg) {
  std::vector<RegistrationResult> runs;
  for (int i = 0; i < std::max(1, repeat); ++i) runs.push_back(reg());
  std::sort(runs.begin(), runs.end(), [](const RegistrationResult& a, const RegistrationResult& b) {
    return a.seconds.total < b.seconds.total;
  });
  return std::move(runs[runs.size() / 2]);
}

/// The predicted error of one of our registrations at the case's landmarks (row.unc_*).
void score_uncertainty(Row& row, const constraints::RegistrationModel& model,
                       const RegistrationResult& r, const CaseData& c,
                       const constraints::IntraopData& data, ConstRef<MatrixX3d> predicted) {
  const constraints::UncertaintyResult u =
      constraints::predict_uncertainty(model, r, RegistrationOptions{});
  row.unc_s = u.seconds;
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

/// TRE of a result against the case's landmarks: a pre-operative landmark X is predicted at
/// T⁻¹ (X + u(X)), u interpolated in its tetrahedron (landmarks up to 20 mm outside the mesh are
/// projected onto it; none are on the phantoms, which landmark the brain).
void score(Row& row, const constraints::RegistrationModel& model, const RegistrationResult& r,
           const CaseData& c, const constraints::IntraopData& data) {
  row.iterations = r.iterations;
  row.converged = r.converged;
  row.stop = constraints::to_string(r.stop);
  row.rows = r.history.empty() ? 0 : r.history.back().rows;
  row.t = r.seconds;
  row.max_displacement_mm =
      r.displacement.rows() ? r.displacement.rowwise().norm().maxCoeff() : 0.0;
  core::MappingOptions mo;
  mo.max_outside_distance = 20.0;
  const core::BarycentricMapping map(model.mesh(), c.truth.a, mo);
  const MatrixX3d moved = map.apply(r.positions);
  const Eigen::Isometry3d to_intra = r.rigid.transform.inverse();
  MatrixX3d predicted(moved.rows(), 3);
  for (Eigen::Index i = 0; i < moved.rows(); ++i)
    predicted.row(i) = (to_intra * Vector3d(moved.row(i).transpose())).transpose();
  const auto before = imaging::error_stats(imaging::landmark_errors(c.truth.a, c.truth.b));
  const auto after = imaging::error_stats(imaging::landmark_errors(predicted, c.truth.b));
  row.tre_before_mean = before.mean;
  row.tre_before_p95 = before.p95;
  row.tre_mean = after.mean;
  row.tre_p95 = after.p95;
  row.tre_max = after.max;
  row.corrected_pct = imaging::percent_shift_corrected(before.mean, after.mean);
  {
    const std::vector<double> err = imaging::landmark_errors(predicted, c.truth.b);
    double near = 0, far = 0;
    row.landmarks_near = row.landmarks_far = 0;
    for (Eigen::Index i = 0; i < c.truth.b.rows() && data.vessel_points.rows() > 0; ++i) {
      const double d =
          (data.vessel_points.rowwise() - c.truth.b.row(i)).rowwise().norm().minCoeff();
      if (d <= 5.0) near += err[static_cast<std::size_t>(i)], ++row.landmarks_near;
      if (d > 10.0) far += err[static_cast<std::size_t>(i)], ++row.landmarks_far;
    }
    row.tre_near_mean =
        row.landmarks_near ? near / static_cast<double>(row.landmarks_near) : std::nan("");
    row.tre_far_mean =
        row.landmarks_far ? far / static_cast<double>(row.landmarks_far) : std::nan("");
  }
  if (!r.data_rows.empty() && row.method != "prescribed_displacement")
    score_uncertainty(row, model, r, c, data, predicted);
  if (row.corrected_pct) *row.corrected_pct += 0.0;  // no "-0.0" in the tables
  row.ok = r.positions.allFinite() && std::isfinite(after.mean);
  if (!row.ok) row.error = "non-finite result";
}

/// Runs `f` (which fills the row) with the peak memory measured and any error recorded.
template <typename F>
Row measured(Row row, const Progress& progress, F&& f) {
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

void describe(Row& row, const Session& s, const constraints::IntraopData& data) {
  row.nodes = s.model->mesh().num_nodes();
  row.tets = s.model->mesh().num_tets();
  row.surface_vertices = static_cast<index_t>(s.model->surface().vertices.rows());
  row.skeleton_points = static_cast<index_t>(s.model->skeleton().points.rows());
  row.vessel_points = static_cast<index_t>(data.vessel_points.rows());
  row.footprint_points = static_cast<index_t>(data.footprint_points.rows());
  row.setup_s = s.seconds_load;
}

/// The product's defaults for the benchmark: the scene's options, vessels only (as the demo:
/// the footprint rows currently cost accuracy on the phantoms; the constraint-set sweep shows it).
RegistrationOptions product_options(const Session& s) {
  RegistrationOptions o = s.loaded.scene.options;
  o.use_footprint = false;
  return o;
}

// --- fits and outputs -----------------------------------------------------------------------

/// Least-squares slope of log y against log x over the positive pairs; nullopt with < 2 (or a
/// degenerate x range).
std::optional<double> log_slope(const std::vector<std::pair<double, double>>& xy) {
  double n = 0, sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (const auto& [x, y] : xy)
    if (x > 0 && y > 0) {
      const double lx = std::log(x), ly = std::log(y);
      n += 1;
      sx += lx;
      sy += ly;
      sxx += lx * lx;
      sxy += lx * ly;
    }
  const double den = n * sxx - sx * sx;
  if (n < 2 || std::abs(den) < 1e-12) return std::nullopt;
  return (n * sxy - sx * sy) / den;
}

nlohmann::json row_json(const Row& r) {
  nlohmann::json j = {
      {"suite", r.suite},
      {"case", r.case_name},
      {"seed", r.seed},
      {"sweep", r.sweep},
      {"value", r.value},
      {"method", r.method},
      {"nodes", r.nodes},
      {"tets", r.tets},
      {"surface_vertices", r.surface_vertices},
      {"skeleton_points", r.skeleton_points},
      {"vessel_points", r.vessel_points},
      {"footprint_points", r.footprint_points},
      {"rows", r.rows},
      {"iterations", r.iterations},
      {"converged", r.converged},
      {"stop", r.stop},
      {"prepare_s", r.prepare_s},
      {"setup_s", r.setup_s},
      {"rigid_s", r.t.rigid},
      {"pairing_s", r.t.pairing},
      {"free_motion_s", r.t.free_motion},
      {"delassus_s", r.t.delassus},
      {"pgs_s", r.t.pgs},
      {"correction_s", r.t.correction},
      {"registration_s", r.t.total},
      {"rss_before_mib", r.rss_before_mib},
      {"peak_rss_mib", r.peak_rss_mib},
      {"tre_before_mean_mm", r.tre_before_mean},
      {"tre_before_p95_mm", r.tre_before_p95},
      {"tre_mean_mm", r.tre_mean},
      {"tre_p95_mm", r.tre_p95},
      {"tre_max_mm", r.tre_max},
      {"tre_near_mean_mm",
       std::isfinite(r.tre_near_mean) ? nlohmann::json(r.tre_near_mean) : nlohmann::json(nullptr)},
      {"landmarks_near", r.landmarks_near},
      {"tre_far_mean_mm",
       std::isfinite(r.tre_far_mean) ? nlohmann::json(r.tre_far_mean) : nlohmann::json(nullptr)},
      {"landmarks_far", r.landmarks_far},
      {"shift_corrected_pct",
       r.corrected_pct ? nlohmann::json(*r.corrected_pct) : nlohmann::json(nullptr)},
      {"max_displacement_mm", r.max_displacement_mm},
      {"ok", r.ok},
      {"error", r.error},
      {"note", r.note}};
  auto opt = [](const std::optional<double>& v) {
    return v ? nlohmann::json(*v) : nlohmann::json(nullptr);
  };
  const auto& cal = r.unc_calibration;
  j["uncertainty_s"] = opt(r.unc_s);
  j["uncertainty_median_mm"] = opt(r.unc_median_mm);
  j["uncertainty_landmarks_mean_mm"] = opt(r.unc_landmarks_mm);
  j["uncertainty_near_mean_mm"] = opt(r.unc_near_mm);
  j["uncertainty_far_mean_mm"] = opt(r.unc_far_mm);
  j["uncertainty_spearman"] = cal ? nlohmann::json(cal->spearman) : nlohmann::json(nullptr);
  j["uncertainty_within_1_sigma_pct"] =
      cal ? nlohmann::json(cal->within_1_sigma_pct) : nlohmann::json(nullptr);
  j["uncertainty_within_2_sigma_pct"] =
      cal ? nlohmann::json(cal->within_2_sigma_pct) : nlohmann::json(nullptr);
  j["uncertainty_rms_ratio"] = cal ? nlohmann::json(cal->rms_ratio) : nlohmann::json(nullptr);
  return j;
}

std::string csv_field(const nlohmann::json& v) {
  if (v.is_null()) return "";
  if (v.is_string()) {
    std::string s = v.get<std::string>();
    if (s.find_first_of(",\"\n") == std::string::npos) return s;
    std::string q = "\"";
    for (char ch : s) q += ch == '"' ? std::string("\"\"") : std::string(1, ch == '\n' ? ' ' : ch);
    return q + "\"";
  }
  if (v.is_boolean()) return v.get<bool>() ? "true" : "false";
  if (v.is_number_float()) {
    std::ostringstream o;
    o << std::setprecision(6) << v.get<double>();
    return o.str();
  }
  return v.dump();
}

void write_csv(const std::filesystem::path& path, const std::vector<Row>& rows) {
  imaging::write_atomically(path, [&](const std::filesystem::path& tmp) {
    std::ofstream f(tmp);
    const nlohmann::json first = row_json(Row{});
    bool head = true;
    for (auto it = first.begin(); it != first.end(); ++it)
      f << (head ? "" : ",") << it.key(), head = false;
    f << '\n';
    for (const Row& r : rows) {
      const nlohmann::json j = row_json(r);
      bool firstcol = true;
      for (auto it = j.begin(); it != j.end(); ++it)
        f << (firstcol ? "" : ",") << csv_field(it.value()), firstcol = false;
      f << '\n';
    }
    BS_VERIFY(f.good(), tmp.string() << ": write failed");
  });
}

std::string fixed(double v, int digits) {
  std::ostringstream o;
  o << std::fixed << std::setprecision(digits) << v;
  return o.str();
}

std::string label(const Row& r) {
  if (r.suite == "cases") return r.method;
  return r.sweep + "=" + r.value;
}

void write_markdown(const std::filesystem::path& path, const std::vector<Row>& rows,
                    const nlohmann::json& meta) {
  std::ostringstream o;
  o << "Benchmark " << meta["machine"]["date"].get<std::string>() << ", "
    << meta["machine"]["cpu"].get<std::string>() << " (" << meta["machine"]["hardware_threads"]
    << " threads), " << meta["machine"]["build_type"].get<std::string>() << " build, seed "
    << meta["seed"] << ", times of the median of " << meta["repeat"] << " registration(s) per run"
    << (meta["quick"].get<bool>() ? ", --quick" : "") << ".\n\n";
  o << "| suite | case | run | nodes | vessel pts | footprint pts | rows | iter | stop | prepare s "
       "| set-up s "
       "| registration s | peak MiB | TRE before mm | TRE mean mm | TRE p95 mm | corrected % | TRE "
       "near (n) | TRE far (n) |\n";
  o << "|---|---|---|--:|--:|--:|--:|--:|---|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|\n";
  for (const Row& r : rows) {
    o << "| " << r.suite << " | " << r.case_name << " | " << label(r) << " | " << r.nodes << " | "
      << r.vessel_points << " | " << r.footprint_points << " | " << r.rows << " | " << r.iterations
      << " | " << (r.ok ? r.stop : "FAILED: " + r.error) << " | "
      << (r.prepare_s > 0 ? fixed(r.prepare_s, 2) : "") << " | " << fixed(r.setup_s, 2) << " | "
      << fixed(r.t.total, 3) << " | " << fixed(r.peak_rss_mib, 0) << " | "
      << fixed(r.tre_before_mean, 2) << " | " << fixed(r.tre_mean, 2) << " | "
      << fixed(r.tre_p95, 2) << " | " << (r.corrected_pct ? fixed(*r.corrected_pct, 1) : "–")
      << " | " << (r.landmarks_near ? fixed(r.tre_near_mean, 2) : "–") << " (" << r.landmarks_near
      << ") | " << (r.landmarks_far ? fixed(r.tre_far_mean, 2) : "–") << " (" << r.landmarks_far
      << ") |\n";
  }
  bool unc = false;
  for (const Row& r : rows)
    if (r.unc_calibration) {
      if (!unc)
        o << "\nPredicted error (sigma = predicted RMS 3-D error; a calibrated Gaussian has 60.8 % "
             "within 1 sigma, "
             "99.3 % within 2):\n\n| suite | case | run | s | median mm | at landmarks mm | near "
             "mm | far mm | Spearman "
             "| within 1σ % | within 2σ % | RMS actual/predicted "
             "|\n|---|---|---|--:|--:|--:|--:|--:|--:|--:|--:|--:|\n";
      unc = true;
      const auto f = [](const std::optional<double>& v, int d) {
        return v ? fixed(*v, d) : std::string("–");
      };
      o << "| " << r.suite << " | " << r.case_name << " | " << label(r) << " | " << f(r.unc_s, 3)
        << " | " << f(r.unc_median_mm, 2) << " | " << f(r.unc_landmarks_mm, 2) << " | "
        << f(r.unc_near_mm, 2) << " | " << f(r.unc_far_mm, 2) << " | "
        << fixed(r.unc_calibration->spearman, 2) << " | "
        << fixed(r.unc_calibration->within_1_sigma_pct, 0) << " | "
        << fixed(r.unc_calibration->within_2_sigma_pct, 0) << " | "
        << fixed(r.unc_calibration->rms_ratio, 2) << " |\n";
    }
  bool notes = false;
  for (const Row& r : rows)
    if (!r.note.empty()) {
      o << (notes ? "" : "\nNotes:\n\n") << "- " << r.case_name << " " << label(r) << ": " << r.note
        << "\n";
      notes = true;
    }
  if (meta.contains("fits") && !meta["fits"].empty()) {
    o << "\nObserved growth (least-squares slope of log–log):\n\n";
    for (auto it = meta["fits"].begin(); it != meta["fits"].end(); ++it)
      o << "- `" << it.key() << "`: " << fixed(it.value().get<double>(), 2) << "\n";
  }
  imaging::write_atomically(path, [&](const std::filesystem::path& tmp) {
    std::ofstream f(tmp);
    f << o.str();
    BS_VERIFY(f.good(), tmp.string() << ": write failed");
  });
}

/// Time against TRE for the runs on `standard` (and all cases' defaults), the Pareto front
/// (runs no other run beats in both) drawn through them. Returns "" or why there is no plot.
std::string write_pareto(const std::filesystem::path& dir, const std::vector<Row>& rows) {
  std::vector<const Row*> pts;
  for (const Row& r : rows)
    if (r.ok && r.case_name == "standard" && r.t.total > 0) pts.push_back(&r);
  if (pts.empty()) return "no finite run on 'standard' to plot";
  std::sort(pts.begin(), pts.end(),
            [](const Row* a, const Row* b) { return a->t.total < b->t.total; });
  {
    std::ofstream d(dir / "pareto.dat");
    d << "# registration_s tre_mean_mm label\n";
    for (const Row* r : pts) d << r->t.total << ' ' << r->tre_mean << " \"" << label(*r) << "\"\n";
    std::ofstream f(dir / "pareto_front.dat");
    double best = std::numeric_limits<double>::infinity();
    for (const Row* r : pts)
      if (r->tre_mean < best) {
        best = r->tre_mean;
        f << r->t.total << ' ' << r->tre_mean << '\n';
      }
  }
  std::ofstream g(dir / "pareto.gp");
  g << "# gnuplot pareto.gp (run in this folder) redraws pareto.png\n"
       "set terminal pngcairo size 1100,750 font ',10' noenhanced\n"
       "set output 'pareto.png'\n"
       "set logscale x\n"
       "set grid\n"
       "set key outside bottom center horizontal\n"
       "set title \"brainshift bench: time against error, phantom 'standard'\"\n"
       "set xlabel 'registration time, s (wall; log scale)'\n"
       "set ylabel 'mean TRE, mm'\n"
       "plot 'pareto.dat' using 1:2 with points pt 7 ps 1.2 title 'runs', \\\n"
       "     '' using 1:2:3 with labels offset char 1,0.6 left font ',8' notitle, \\\n"
       "     'pareto_front.dat' using 1:2 with steps lw 2 title 'Pareto front'\n";
  g.close();
  const std::string cmd = "cd '" + dir.string() + "' && gnuplot pareto.gp > gnuplot.log 2>&1";
  if (std::system(cmd.c_str()) != 0 || !std::filesystem::exists(dir / "pareto.png"))
    return "gnuplot failed (see gnuplot.log; scripts/install_deps.sh installs gnuplot-nox)";
  std::filesystem::remove(dir / "gnuplot.log");
  return "";
}

}  // namespace

CLI::App* add_bench_command(CLI::App& app, BenchArgs& args) {
  CLI::App* c = app.add_subcommand(
      "bench", "Speed against error on the phantom cases: sweeps, baselines, Pareto plot");
  c->add_flag("--quick", args.quick, "standard case and a few sweep points (< 2 min)");
  c->add_option("--suite", args.suite,
                "all, cases (every named case + baselines) or sweeps (on standard)")
      ->check(CLI::IsMember({"all", "cases", "sweeps"}))
      ->capture_default_str();
  c->add_option("--cases", args.cases, "named cases for the cases suite (default: all)")
      ->delimiter(',');
  c->add_option("--seed", args.seed, "phantom seed")->capture_default_str();
  c->add_option("--repeat", args.repeat, "registrations per run; times are of the median run")
      ->check(CLI::Range(1, 50))
      ->capture_default_str();
  c->add_flag("--keep-work", args.keep_work, "keep DIR/work (phantoms and models)");
  c->add_option("--real-data", args.real_data,
                "real data folder: the icbm_* cases read DIR/icbm152/labels.nii.gz and are skipped "
                "when it is "
                "absent (default: $BRAINSHIFT_DATA, else ../shared/data)");
  c->add_option("--out", args.out,
                "output folder DIR (results.csv, results.json, results.md, pareto.png)")
      ->required();
  return c;
}

int run_bench(const BenchArgs& args, std::ostream& out) {
  const Progress progress("bench");
  verify_output_folder(args.out);
  std::vector<std::string> cases = args.cases;
  std::vector<std::string> known = data_synth::case_names();
  known.insert(known.end(), real_anatomy_cases.begin(), real_anatomy_cases.end());
  for (const auto& c : cases)
    BS_VERIFY(std::find(known.begin(), known.end(), c) != known.end(),
              "bench: unknown case '" << c << "'");
  if (cases.empty()) cases = args.quick ? std::vector<std::string>{"standard"} : known;
  std::filesystem::path real_data = args.real_data;
  if (real_data.empty()) {
    const char* env = std::getenv("BRAINSHIFT_DATA");
    real_data = env && *env ? std::filesystem::path(env) : std::filesystem::path("../shared/data");
  }
  std::vector<std::string> skipped;
  if (!std::filesystem::is_regular_file(icbm_labels(real_data))) {
    for (const auto& c : cases)
      if (is_real_anatomy_case(c)) {
        skipped.push_back(c);
        std::cerr << "brainshift bench: skipping " << c << ": " << icbm_labels(real_data).string()
                  << " is absent (--real-data DIR)\n";
      }
    std::erase_if(cases, is_real_anatomy_case);
  }
  const bool do_cases = args.suite != "sweeps", do_sweeps = args.suite != "cases";

  std::vector<Row> rows;
  nlohmann::json meta = {
      {"machine", machine()},
      {"seed", args.seed},
      {"quick", args.quick},
      {"repeat", args.repeat},
      {"suite", args.suite},
      {"skipped", skipped},
      {"note",
       "times are wall seconds of this process (2 threads at most); peak_rss_mib is the "
       "process's high-water mark during the run (kernel VmHWM, reset before each run)"}};
  write_folder_atomically(args.out, [&](const std::filesystem::path& dir) {
    const auto work = dir / "work";
    std::filesystem::create_directories(work);
    std::map<std::string, CaseData> made;
    auto case_data = [&](const std::string& name) -> const CaseData& {
      if (!made.count(name)) {
        progress.stage("phantom '" + name + "' (seed " + std::to_string(args.seed) + ")");
        made.emplace(name, make_case(name, args.seed, work / name / "phantom", real_data));
      }
      return made.at(name);
    };
    auto base_row = [&](const std::string& suite, const std::string& name) {
      Row r;
      r.suite = suite;
      r.case_name = name;
      r.seed = args.seed;
      r.method = "constraint_icp";
      return r;
    };

    // Suite `cases`: each case with the defaults, and the two baselines.
    std::optional<double> standard_prepare_s;
    if (do_cases)
      for (const std::string& name : cases) {
        Row failed = base_row("cases", name);
        try {
          const CaseData& c = case_data(name);
          const auto model_dir = work / name / "model";
          progress.stage(name + ": prepare");
          const double prepare_s = prepare(c, model_dir, 1.0);
          if (name == "standard") standard_prepare_s = prepare_s;
          Session s = open_session(model_dir);
          constraints::IntraopData data;
          data.vessel_points = doppler_points(s, c, 2.5);
          const RegistrationOptions o = product_options(s);
          // Variants of our loop (full runs only; --quick keeps the three methods):
          // block_cv — the vessel compliance chosen by leave-one-branch-out cross-validation in a
          // SMOOTH stage, from a rigid-only global start (off by default: bimodal with the mesh);
          // gcv_compliance — the same stage at the compliance chosen by generalised
          // cross-validation; dura_sliding / dura_unilateral — dura contact
          // outside the craniotomy on (the default is none): what the boundary conditions do off
          // the vessels (far-landmark TRE).
          std::map<std::string, RegistrationOptions> variants;
          variants["constraint_icp"] = o;
          std::vector<std::string> methods = {"constraint_icp"};
          if (!args.quick) {
            variants["block_cv"] = o;
            variants["block_cv"].noise.enabled = true;
            variants["block_cv"].global_start.bulk_response = false;
            variants["gcv_compliance"] = o;
            variants["gcv_compliance"].noise.enabled = true;
            variants["gcv_compliance"].global_start.bulk_response = false;
            variants["gcv_compliance"].noise.criterion = constraints::NoiseCriterion::GCV;
            variants["dura_sliding"] = o;
            variants["dura_sliding"].dura.mode = constraints::DuraOptions::Mode::SLIDING;
            variants["dura_unilateral"] = o;
            variants["dura_unilateral"].dura.mode = constraints::DuraOptions::Mode::UNILATERAL;
            methods.insert(methods.end(),
                           {"block_cv", "gcv_compliance", "dura_sliding", "dura_unilateral"});
          }
          methods.insert(methods.end(), {"rigid_only", "prescribed_displacement"});
          for (const std::string& method : methods) {
            Row row = base_row("cases", name);
            row.method = method;
            rows.push_back(measured(row, progress, [&](Row& r) {
              describe(r, s, data);
              r.prepare_s = prepare_s;
              const std::string& m = method;
              const RegistrationResult res = median_of(args.repeat, [&] {
                return m == "rigid_only" ? rigid_only(*s.model, data, o)
                       : m == "prescribed_displacement"
                           ? prescribed_displacement(*s.model, data, o)
                           : constraints::register_model(*s.model, data, variants.at(m));
              });
              score(r, *s.model, res, c, data);
              // Which vessel compliance the loop ended with (the noise model's choice, if applied).
              if (variants.count(m) && res.noise.valid)
                r.note = variants.at(m).noise.enabled
                             ? "vessel compliance: " + res.noise.message
                             : "vessel compliance fixed; " + res.noise.message;
            }));
          }
        } catch (const std::exception& e) {  // the case itself could not be built
          failed.error = e.what();
          rows.push_back(failed);
        }
      }

    if (do_sweeps) {
      const std::string name = "standard";
      try {
        const CaseData& c = case_data(name);

        // Mesh size: a model per refinement (the pre-operative cost is part of the figure).
        const std::vector<double> refine =
            args.quick ? std::vector<double>{0.85, 1.1}
                       : std::vector<double>(std::begin(refinements), std::end(refinements));
        for (double r : refine) {
          Row row = base_row("sweeps", name);
          row.sweep = "mesh_size";
          row.value = "refine " + fixed(r, 2);
          rows.push_back(measured(row, progress, [&](Row& out_row) {
            const auto model_dir = work / name / ("model_r" + fixed(r, 2));
            out_row.prepare_s = prepare(c, model_dir, r);
            Session s = open_session(model_dir);
            constraints::IntraopData data;
            data.vessel_points = doppler_points(s, c, 2.5);
            describe(out_row, s, data);
            out_row.value = std::to_string(s.model->mesh().num_nodes()) + " nodes";
            score(out_row, *s.model,
                  median_of(args.repeat,
                            [&] {
                              return constraints::register_model(*s.model, data,
                                                                 product_options(s));
                            }),
                  c, data);
            std::filesystem::remove_all(
                model_dir);  // 50k-node models are large; the figures are kept
          }));
        }

        const auto model_dir = work / name / "model";
        if (!std::filesystem::exists(model_dir)) standard_prepare_s = prepare(c, model_dir, 1.0);
        Session s = open_session(model_dir);
        constraints::IntraopData data;
        data.vessel_points = doppler_points(s, c, 2.5);
        auto sweep = [&](const std::string& what, const std::string& value,
                         const constraints::IntraopData& d, const RegistrationOptions& o,
                         constraints::RegistrationModel* model = nullptr) {
          Row row = base_row("sweeps", name);
          row.sweep = what;
          row.value = value;
          rows.push_back(measured(row, progress, [&](Row& r) {
            describe(r, s, d);
            r.prepare_s = standard_prepare_s.value_or(0.0);
            constraints::RegistrationModel& m = model ? *model : *s.model;
            score(r, m,
                  median_of(args.repeat, [&] { return constraints::register_model(m, d, o); }), c,
                  d);
          }));
        };

        // The start: identity, or the robust rigid fit (which also absorbs any bulk brain motion).
        for (const auto start :
             {constraints::RigidStart::IDENTITY, constraints::RigidStart::RIGID}) {
          RegistrationOptions o = product_options(s);
          o.start = start;
          sweep("start", start == constraints::RigidStart::RIGID ? "rigid" : "identity", data, o);
        }

        // Intra-operative vessel sampling.
        for (double step :
             args.quick ? std::vector<double>{5.0} : std::vector<double>{1.25, 2.5, 5.0}) {
          constraints::IntraopData d;
          d.vessel_points = doppler_points(s, c, step);
          sweep("vessel_sampling", fixed(step, 2) + " mm", d, product_options(s));
        }

        // Compliance strategy: the precomputed block (default), per-iteration sparse solves (a
        // model of its own: the strategy is chosen when the model is built), unwarped K0
        // (ablation).
        sweep("compliance", "dense_block", data, product_options(s));
        {
          constraints::ComplianceOptions sparse = s.loaded.scene.compliance;
          sparse.strategy = constraints::ComplianceStrategy::SPARSE_SOLVE;
          const auto& sc = s.loaded.scene;
          constraints::RegistrationModel m(sc.mesh, sc.fixed_nodes, sc.skeleton, sc.surface,
                                           sparse);
          sweep("compliance", "sparse_solve", data, product_options(s), &m);
        }
        {
          RegistrationOptions o = product_options(s);
          o.step.mechanics = constraints::Mechanics::UNWARPED;
          sweep("compliance", "unwarped_K0", data, o);
        }

        // PGS tolerance, with Gauss–Seidel forced (the default active-set solve is exact and
        // uses PGS only to verify).
        for (double tol : args.quick ? std::vector<double>{1e-2, 1e-4}
                                     : std::vector<double>{1e-2, 1e-3, 1e-4, 1e-6}) {
          RegistrationOptions o = product_options(s);
          o.step.solver = constraints::ConstraintSolver::GAUSS_SEIDEL;
          o.step.pgs.tolerance = tol;
          std::ostringstream v;
          v << "gs " << tol;
          sweep("pgs_tolerance", v.str(), data, o);
        }

        // Constraint sets.
        {
          constraints::IntraopData with_fp = data;
          const IntraopFootprint fp = footprint_from_bmode(c.phantom / "intraop/bmode.nii.gz");
          with_fp.footprint_points = fp.points;
          with_fp.footprint_normals = fp.normals;
          const std::string fp_note =
              fp.points.rows()
                  ? ""
                  : "the B-mode gave no footprint: " + fp.report.value("message", std::string());
          RegistrationOptions o = s.loaded.scene.options;
          o.use_footprint = false;
          sweep("constraint_sets", "vessels", data, o);
          o.use_footprint = true;
          sweep("constraint_sets", "vessels+footprint", with_fp, o);
          rows.back().note = fp_note;
          if (!args.quick) {
            o.dura.mode = constraints::DuraOptions::Mode::SLIDING;
            sweep("constraint_sets", "vessels+footprint+dura", with_fp, o);
            rows.back().note = fp_note;
          }
        }
      } catch (const std::exception& e) {
        Row failed = base_row("sweeps", name);
        failed.error = e.what();
        rows.push_back(failed);
      }
    }

    // Growth with mesh size and constraint count.
    nlohmann::json fits = nlohmann::json::object();
    std::vector<std::pair<double, double>> reg, per_it, prep, wp;
    for (const Row& r : rows) {
      if (!r.ok) continue;
      if (r.sweep == "mesh_size") {
        reg.emplace_back(r.nodes, r.t.total);
        if (r.iterations > 0) per_it.emplace_back(r.nodes, r.t.total / r.iterations);
        prep.emplace_back(r.nodes, r.prepare_s);
      }
      if ((r.sweep == "vessel_sampling" || r.sweep == "constraint_sets") && r.iterations > 0)
        wp.emplace_back(r.rows, (r.t.delassus + r.t.pgs) / r.iterations);
    }
    if (auto k = log_slope(reg)) fits["registration_s_vs_nodes"] = *k;
    if (auto k = log_slope(per_it)) fits["seconds_per_iteration_vs_nodes"] = *k;
    if (auto k = log_slope(prep)) fits["prepare_s_vs_nodes"] = *k;
    if (auto k = log_slope(wp)) fits["delassus_plus_pgs_per_iteration_vs_rows"] = *k;
    meta["fits"] = fits;

    const std::string plot = write_pareto(dir, rows);
    meta["plot"] = plot.empty() ? nlohmann::json("pareto.png") : nlohmann::json(plot);
    nlohmann::json all = meta;
    all["runs"] = nlohmann::json::array();
    for (const Row& r : rows) all["runs"].push_back(row_json(r));
    write_csv(dir / "results.csv", rows);
    std::ofstream(dir / "results.json") << all.dump(2) << '\n';
    write_markdown(dir / "results.md", rows, meta);
    if (!args.keep_work) std::filesystem::remove_all(work);
  });

  int failed = 0;
  out << std::fixed << std::setprecision(2);
  out << "brainshift bench: " << rows.size() << " runs in " << progress.seconds() << " s\n";
  for (const Row& r : rows) {
    if (!r.ok) ++failed;
    if (r.suite != "cases") continue;
    out << "  " << std::left << std::setw(30) << r.case_name << std::setw(24) << r.method
        << std::right;
    if (r.ok)
      out << " TRE " << r.tre_before_mean << " -> " << r.tre_mean << " mm (near " << r.tre_near_mean
          << ", far " << r.tre_far_mean << "), " << r.t.total << " s, " << r.stop << "\n";
    else
      out << " FAILED: " << r.error << "\n";
  }
  out << "  results: " << (args.out / "results.md").string() << ", results.csv, results.json"
      << (meta["plot"] == "pareto.png" ? ", pareto.png" : "") << "\n";
  if (meta["plot"] != "pareto.png")
    out << "  warning: no plot: " << meta["plot"].get<std::string>() << "\n";
  if (failed) out << "  " << failed << " run(s) failed; see results.md\n";
  return failed ? 2 : 0;
}

}  // namespace brainshift::apps
