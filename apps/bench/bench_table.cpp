#include "apps/bench/bench_table.hpp"

#include "core/error.hpp"
#include "imaging/io/atomic_write.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iomanip>
#include <limits>
#include <sstream>

namespace brainshift::workflow {
namespace {

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

}  // namespace

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

nlohmann::json row_json(const BenchRow& r) {
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
      {"dense_error_mean_mm",
       r.dense_error_mean ? nlohmann::json(*r.dense_error_mean) : nlohmann::json(nullptr)},
      {"dense_before_mean_mm",
       r.dense_before_mean ? nlohmann::json(*r.dense_before_mean) : nlohmann::json(nullptr)},
      {"dense_deep_error_mean_mm", r.dense_deep_error_mean
                                       ? nlohmann::json(*r.dense_deep_error_mean)
                                       : nlohmann::json(nullptr)},
      {"dense_deep_before_mean_mm", r.dense_deep_before_mean
                                        ? nlohmann::json(*r.dense_deep_before_mean)
                                        : nlohmann::json(nullptr)},
      {"dense_deep_points", r.dense_deep_points},
      {"max_displacement_mm", r.max_displacement_mm},
      {"fixed_base_moved_mm", r.fixed_base_moved_mm},
      {"ok", r.ok},
      {"stop_reason", r.stop_reason},
      {"error", r.error},
      {"note", r.note}};
  auto opt = [](const std::optional<double>& v) {
    return v ? nlohmann::json(*v) : nlohmann::json(nullptr);
  };
  const auto& cal = r.unc_calibration;
  j["uncertainty_s"] = opt(r.unc_s);
  j["uncertainty_cpu_s"] = opt(r.unc_cpu_s);
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
  j["uncertainty_s2_mn_mm"] = opt(r.unc_s2);
  j["uncertainty_s2_ml_mn_mm"] = opt(r.unc_s2_ml);
  j["uncertainty_s2_restricted_mn_mm"] = opt(r.unc_s2_restricted);
  j["uncertainty_s2_heldout_mn_mm"] = opt(r.unc_s2_heldout);
  j["uncertainty_s2_estimator"] =
      r.unc_s2_estimator.empty() ? nlohmann::json(nullptr) : nlohmann::json(r.unc_s2_estimator);
  j["uncertainty_rows"] = opt(r.unc_rows);
  j["uncertainty_heldout_blocks"] = opt(r.unc_heldout_blocks);
  j["uncertainty_tracking_mm"] = r.unc_tracking_mm;
  j["uncertainty_tracking_deg"] = r.unc_tracking_deg;
  // Dense calibration (bench_dense.hpp): the same figures at points inside the brain.
  const auto& d = r.unc_dense;
  auto num = [](double v) {
    return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr);
  };
  j["uncertainty_dense_points"] = d ? nlohmann::json(d->cal.count) : nlohmann::json(nullptr);
  j["uncertainty_dense_spearman"] = d ? num(d->cal.spearman) : nlohmann::json(nullptr);
  j["uncertainty_dense_within_1_sigma_pct"] =
      d ? num(d->cal.within_1_sigma_pct) : nlohmann::json(nullptr);
  j["uncertainty_dense_within_2_sigma_pct"] =
      d ? num(d->cal.within_2_sigma_pct) : nlohmann::json(nullptr);
  j["uncertainty_dense_rms_ratio"] = d ? num(d->cal.rms_ratio) : nlohmann::json(nullptr);
  j["uncertainty_dense_mean_mm"] = d ? num(d->cal.mean_predicted_mm) : nlohmann::json(nullptr);
  j["uncertainty_dense_actual_mean_mm"] = d ? num(d->cal.mean_actual_mm) : nlohmann::json(nullptr);
  j["uncertainty_dense_near_mean_mm"] = d ? num(d->near_predicted_mm) : nlohmann::json(nullptr);
  j["uncertainty_dense_far_mean_mm"] = d ? num(d->far_predicted_mm) : nlohmann::json(nullptr);
  j["uncertainty_dense_actual_near_mean_mm"] = d ? num(d->near_actual_mm) : nlohmann::json(nullptr);
  j["uncertainty_dense_actual_far_mean_mm"] = d ? num(d->far_actual_mm) : nlohmann::json(nullptr);
  j["uncertainty_dense_near_points"] = d ? nlohmann::json(d->near) : nlohmann::json(nullptr);
  j["uncertainty_dense_far_points"] = d ? nlohmann::json(d->far) : nlohmann::json(nullptr);
  return j;
}

void write_csv(const std::filesystem::path& path, const std::vector<BenchRow>& rows) {
  imaging::write_atomically(path, [&](const std::filesystem::path& tmp) {
    std::ofstream f(tmp);
    const nlohmann::json first = row_json(BenchRow{});
    bool head = true;
    for (auto it = first.begin(); it != first.end(); ++it)
      f << (head ? "" : ",") << it.key(), head = false;
    f << '\n';
    for (const BenchRow& r : rows) {
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

std::string label(const BenchRow& r) {
  if (r.suite == "cases") return r.method;
  return r.sweep + "=" + r.value;
}

void write_markdown(const std::filesystem::path& path, const std::vector<BenchRow>& rows,
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
  for (const BenchRow& r : rows) {
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
  for (const BenchRow& r : rows)
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
  for (const BenchRow& r : rows)
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

std::string write_pareto(const std::filesystem::path& dir, const std::vector<BenchRow>& rows) {
  std::vector<const BenchRow*> pts;
  for (const BenchRow& r : rows)
    if (r.ok && r.case_name == "standard" && r.t.total > 0) pts.push_back(&r);
  if (pts.empty()) return "no finite run on 'standard' to plot";
  std::sort(pts.begin(), pts.end(),
            [](const BenchRow* a, const BenchRow* b) { return a->t.total < b->t.total; });
  {
    std::ofstream d(dir / "pareto.dat");
    d << "# registration_s tre_mean_mm label\n";
    for (const BenchRow* r : pts)
      d << r->t.total << ' ' << r->tre_mean << " \"" << label(*r) << "\"\n";
    std::ofstream f(dir / "pareto_front.dat");
    double best = std::numeric_limits<double>::infinity();
    for (const BenchRow* r : pts)
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

}  // namespace brainshift::workflow
