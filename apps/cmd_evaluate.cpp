#include "cmd_evaluate.hpp"

#include "core/error.hpp"
#include "imaging/evaluation/calibration.hpp"
#include "imaging/evaluation/metrics.hpp"
#include "imaging/io/atomic_write.hpp"
#include "imaging/io/csv.hpp"
#include "imaging/io/image_io.hpp"
#include "imaging/io/landmark_files.hpp"
#include "imaging/io/surface_io.hpp"
#include "imaging/warping/warp_image.hpp"

#include <CLI/CLI.hpp>

#include <fstream>
#include <iomanip>
#include <ostream>
#include <sstream>

namespace brainshift::apps {
namespace {

/// The points moved by the displacement field: p + u(p), u trilinear per component.
MatrixX3d moved(const imaging::VolumeF& field, ConstRef<MatrixX3d> p) {
  MatrixX3d out(p.rows(), 3);
  for (Eigen::Index i = 0; i < p.rows(); ++i) {
    const Vector3d ijk = field.geometry.world_to_index(p.row(i).transpose());
    for (int c = 0; c < 3; ++c)
      out(i, c) = p(i, c) + imaging::sample_trilinear(field, ijk, 0.0F, c);
  }
  return out;
}

nlohmann::json stats_json(const imaging::ErrorStats& s) {
  return {
      {"mean", s.mean}, {"median", s.median}, {"p95", s.p95}, {"max", s.max}, {"count", s.count}};
}

nlohmann::json surface_json(const imaging::SurfaceDistanceStats& s) {
  return {{"h95", s.h95}, {"h75", s.h75}, {"h50", s.h50},
          {"h25", s.h25}, {"max", s.max}, {"mean", s.mean}};
}

/// The per-landmark errors as a Slicer markups file: each landmark at its intra-operative
/// (truth) position, labelled with its id, the error after and before in its description.
void write_landmark_errors(const std::filesystem::path& path, const imaging::LandmarkPairs& pairs,
                           ConstRef<MatrixX3d> predicted) {
  const std::vector<double> after = imaging::landmark_errors(predicted, pairs.b);
  const std::vector<double> before = imaging::landmark_errors(pairs.a, pairs.b);
  std::vector<std::string> descriptions;
  for (std::size_t i = 0; i < after.size(); ++i) {
    std::ostringstream d;
    d << std::fixed << std::setprecision(2) << "error " << after[i] << " mm (before registration "
      << before[i] << " mm)";
    descriptions.push_back(d.str());
  }
  imaging::write_markups_json(path, {pairs.ids, pairs.b}, descriptions);
}

}  // namespace

CLI::App* add_evaluate_command(CLI::App& app, EvaluateArgs& args) {
  CLI::App* c =
      app.add_subcommand("evaluate", "TRE and surface distances of a result against truth");
  c->add_option("--result", args.result, "result folder RES from register")->required();
  c->add_option("--landmarks-pre", args.landmarks_pre,
                "pre-operative landmarks: CSV id,x,y,z (RAS mm), MNI .tag (a two-volume file's "
                "first set), Slicer .mrk.json or .fcsv")
      ->required();
  c->add_option("--landmarks-intra", args.landmarks_intra,
                "intra-operative landmarks, the same formats (a two-volume .tag file's second "
                "set: RESECT's CaseN-MRI-beforeUS.tag serves as both)")
      ->required();
  c->add_option("--surface-pre", args.surface_pre, "pre-operative surface .vtp (e.g. ventricles)");
  c->add_option("--surface-intra", args.surface_intra, "intra-operative surface .vtp");
  c->add_option(
      "--brain-points-pre", args.brain_points_pre,
      "points spread over the brain, pre-operative (CSV id,x,y,z, mm): whole-brain error");
  c->add_option("--brain-points-intra", args.brain_points_intra,
                "the same points' truth positions, intra-operative (CSV id,x,y,z, mm)");
  return c;
}

nlohmann::json evaluate(const EvaluateArgs& args) {
  BS_VERIFY(args.surface_pre.has_value() == args.surface_intra.has_value(),
            "evaluate: give both --surface-pre and --surface-intra, or neither");
  BS_VERIFY(args.brain_points_pre.has_value() == args.brain_points_intra.has_value(),
            "evaluate: give both --brain-points-pre and --brain-points-intra, or neither");
  const std::filesystem::path field_path = args.result / "displacement.nii.gz";
  const imaging::VolumeF field = imaging::read_volume(field_path);
  BS_VERIFY(field.components == 3, field_path.string()
                                       << ": expected a 3-component displacement field, got "
                                       << field.components);
  const imaging::Landmarks pre =
      imaging::read_landmark_file(args.landmarks_pre, imaging::TagVolume::FIRST);
  const imaging::Landmarks intra =
      imaging::read_landmark_file(args.landmarks_intra, imaging::TagVolume::SECOND);
  const imaging::LandmarkPairs pairs =
      imaging::match_landmarks_by_id(pre.ids, pre.points, intra.ids, intra.points);
  BS_VERIFY(!pairs.ids.empty(), args.landmarks_pre.string()
                                    << " and " << args.landmarks_intra.string()
                                    << ": no landmark id in common");
  const MatrixX3d predicted = moved(field, pairs.a);
  const imaging::ErrorStats before =
      imaging::error_stats(imaging::landmark_errors(pairs.a, pairs.b));
  const imaging::ErrorStats after =
      imaging::error_stats(imaging::landmark_errors(predicted, pairs.b));
  nlohmann::json j = {{"result", args.result.string()},
                      {"landmarks", pairs.ids.size()},
                      {"unpaired_landmarks", pairs.warnings},
                      {"tre_before_mm", stats_json(before)},
                      {"tre_after_mm", stats_json(after)}};
  // Predicted error: RES/uncertainty.nii.gz at the pre-operative landmarks against
  // their actual errors (imaging/evaluation/calibration.hpp for the convention).
  if (const auto unc_path = args.result / "uncertainty.nii.gz"; std::filesystem::exists(unc_path)) {
    const imaging::VolumeF unc = imaging::read_volume(unc_path);
    BS_VERIFY(unc.components == 1, unc_path.string() << ": expected a scalar map, got "
                                                     << unc.components << " components");
    const std::vector<double> actual = imaging::landmark_errors(predicted, pairs.b);
    std::vector<double> sigma;
    for (Eigen::Index i = 0; i < pairs.a.rows(); ++i)
      sigma.push_back(
          std::max(0.0F, imaging::sample_trilinear(
                             unc, unc.geometry.world_to_index(pairs.a.row(i).transpose()), 0.0F)));
    const imaging::UncertaintyCalibration c = imaging::calibrate_uncertainty(sigma, actual);
    const auto [axis1, axis2] =
        imaging::per_axis_within_sigma_pct(sigma, MatrixX3d(predicted - pairs.b));
    j["uncertainty_calibration"] = {
        {"landmarks", c.count},
        {"spearman", c.spearman},
        {"within_1_sigma_pct", c.within_1_sigma_pct},
        {"within_2_sigma_pct", c.within_2_sigma_pct},
        {"expected_within_1_sigma_pct", imaging::expected_within_1_sigma_pct},
        {"expected_within_2_sigma_pct", imaging::expected_within_2_sigma_pct},
        {"mean_predicted_mm", c.mean_predicted_mm},
        {"mean_actual_mm", c.mean_actual_mm},
        {"rms_actual_over_predicted", c.rms_ratio},
        {"per_axis_within_1_sigma_pct", axis1},
        {"per_axis_within_2_sigma_pct", axis2},
        {"expected_per_axis_within_1_sigma_pct", imaging::expected_per_axis_within_1_sigma_pct},
        {"expected_per_axis_within_2_sigma_pct", imaging::expected_per_axis_within_2_sigma_pct},
        {"predicted_mm", sigma},
        {"convention",
         "sigma = predicted RMS length of the 3-D error (sqrt tr Σ); within k sigma: |e| <= k "
         "sigma; per axis: each component |e_c| <= k sigma/sqrt(3)"}};
  }
  write_landmark_errors(args.result / landmark_errors_file, pairs, predicted);
  j["landmark_errors_file"] = landmark_errors_file;
  const auto pct = imaging::percent_shift_corrected(before.mean, after.mean);
  j["shift_corrected_pct"] = pct ? nlohmann::json(*pct) : nlohmann::json(nullptr);
  if (args.brain_points_pre) {
    const imaging::Landmarks bp =
        imaging::read_landmark_file(*args.brain_points_pre, imaging::TagVolume::FIRST);
    const imaging::Landmarks bi =
        imaging::read_landmark_file(*args.brain_points_intra, imaging::TagVolume::SECOND);
    const imaging::LandmarkPairs b =
        imaging::match_landmarks_by_id(bp.ids, bp.points, bi.ids, bi.points);
    BS_VERIFY(!b.ids.empty(), args.brain_points_pre->string()
                                  << " and " << args.brain_points_intra->string()
                                  << ": no point id in common");
    j["whole_brain_points"] = b.ids.size();
    j["whole_brain_before_mm"] =
        stats_json(imaging::error_stats(imaging::landmark_errors(b.a, b.b)));
    j["whole_brain_after_mm"] =
        stats_json(imaging::error_stats(imaging::landmark_errors(moved(field, b.a), b.b)));
  }
  if (args.surface_pre) {
    core::SurfaceMesh s_pre = imaging::read_surface_vtp(*args.surface_pre);
    const core::SurfaceMesh s_intra = imaging::read_surface_vtp(*args.surface_intra);
    j["surface_before_mm"] = surface_json(imaging::hausdorff_percentiles(s_pre, s_intra));
    s_pre.vertices = moved(field, s_pre.vertices);
    j["surface_after_mm"] = surface_json(imaging::hausdorff_percentiles(s_pre, s_intra));
  }
  imaging::write_atomically(args.result / "evaluation.json", [&](const std::filesystem::path& tmp) {
    std::ofstream f(tmp);
    f << j.dump(2) << '\n';
    BS_VERIFY(f.good(), tmp.string() << ": write failed");
  });
  return j;
}

int run_evaluate(const EvaluateArgs& args, std::ostream& out) {
  const nlohmann::json j = evaluate(args);
  out << std::fixed << std::setprecision(2);
  out << "TRE (mm) over " << j["landmarks"].get<std::size_t>() << " landmarks\n";
  out << "           mean  median     p95     max\n";
  for (const char* k : {"tre_before_mm", "tre_after_mm"}) {
    const auto& s = j[k];
    out << (std::string(k) == "tre_before_mm" ? "  before " : "  after  ") << std::setw(6)
        << s["mean"].get<double>() << std::setw(8) << s["median"].get<double>() << std::setw(8)
        << s["p95"].get<double>() << std::setw(8) << s["max"].get<double>() << "\n";
  }
  if (j.contains("whole_brain_after_mm"))
    out << "whole brain (" << j["whole_brain_points"].get<std::size_t>() << " points): mean "
        << j["whole_brain_before_mm"]["mean"].get<double>() << " -> "
        << j["whole_brain_after_mm"]["mean"].get<double>() << " mm, p95 "
        << j["whole_brain_before_mm"]["p95"].get<double>() << " -> "
        << j["whole_brain_after_mm"]["p95"].get<double>() << " mm\n";
  if (!j["shift_corrected_pct"].is_null())
    out << "shift corrected: " << j["shift_corrected_pct"].get<double>() << " %\n";
  if (j.contains("surface_after_mm"))
    for (const char* k : {"surface_before_mm", "surface_after_mm"})
      out << (std::string(k) == "surface_before_mm" ? "surface before" : "surface after ")
          << ": H95 " << j[k]["h95"].get<double>() << ", H75 " << j[k]["h75"].get<double>()
          << ", H50 " << j[k]["h50"].get<double>() << ", H25 " << j[k]["h25"].get<double>()
          << " mm\n";
  if (j.contains("uncertainty_calibration")) {
    const auto& c = j["uncertainty_calibration"];
    out << "predicted error: Spearman " << c["spearman"].get<double>() << ", within 1 sigma "
        << c["within_1_sigma_pct"].get<double>() << " % (calibrated: 60.8), within 2 sigma "
        << c["within_2_sigma_pct"].get<double>() << " % (calibrated: 99.3); per axis "
        << c["per_axis_within_1_sigma_pct"].get<double>() << " / "
        << c["per_axis_within_2_sigma_pct"].get<double>() << " % (calibrated: 68.3 / 95.4)\n";
  }
  for (const auto& w : j["unpaired_landmarks"]) out << "warning: " << w.get<std::string>() << "\n";
  out << "written: " << (args.result / "evaluation.json").string() << ", "
      << (args.result / landmark_errors_file).string() << "\n";
  return 0;
}

}  // namespace brainshift::apps
