#include "cmd_demo.hpp"

#include "cmd_evaluate.hpp"
#include "cmd_pre_dura.hpp"
#include "cmd_prepare.hpp"
#include "cmd_register.hpp"

#include "apps/bench/bench_dense.hpp"
#include "apps/workflow/pose_file.hpp"
#include "apps/workflow/progress.hpp"
#include "core/error.hpp"
#include "data_synth/cases/phantom_case.hpp"
#include "imaging/io/csv.hpp"

#include <CLI/CLI.hpp>

#include <fstream>
#include <iomanip>
#include <ostream>
#include <sstream>
#include <string>
#include <system_error>

namespace brainshift::apps {
namespace {

/// Points drawn among the phantom's brain voxels with their truth positions (the bench's dense
/// truth), written as two landmark CSVs for `evaluate --brain-points-*`; false (and a note)
/// when the phantom's truth field does not reproduce its landmarks.
bool write_brain_points(const std::filesystem::path& phantom, int count, std::string& note) {
  const imaging::Landmarks pre = imaging::read_landmarks(phantom / "truth/landmarks_preop.csv");
  const imaging::Landmarks intra = imaging::read_landmarks(phantom / "truth/landmarks_intraop.csv");
  const workflow::DenseTruth d = workflow::dense_truth(
      phantom, imaging::match_landmarks_by_id(pre.ids, pre.points, intra.ids, intra.points), count,
      16);
  note = d.note;
  if (d.pre.rows() == 0) return false;
  imaging::Landmarks a, b;
  a.points = d.pre;
  b.points = d.intra;
  for (Eigen::Index i = 0; i < d.pre.rows(); ++i) a.ids.push_back("p" + std::to_string(i));
  b.ids = a.ids;
  imaging::write_landmarks(phantom / "truth/brain_points_preop.csv", a);
  imaging::write_landmarks(phantom / "truth/brain_points_intraop.csv", b);
  return true;
}

/// One summary line of an evaluation: landmarks and, with brain points, the whole brain.
std::string errors_line(const nlohmann::json& ev) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(2) << "landmarks "
    << ev["tre_before_mm"]["mean"].get<double>() << " -> "
    << ev["tre_after_mm"]["mean"].get<double>() << " mm (p95 "
    << ev["tre_after_mm"]["p95"].get<double>() << ", max "
    << ev["tre_after_mm"]["max"].get<double>() << ")";
  if (ev.contains("whole_brain_after_mm"))
    s << "; whole brain " << ev["whole_brain_before_mm"]["mean"].get<double>() << " -> "
      << ev["whole_brain_after_mm"]["mean"].get<double>() << " mm (p95 "
      << ev["whole_brain_after_mm"]["p95"].get<double>() << ")";
  return s.str();
}

}  // namespace

CLI::App* add_demo_command(CLI::App& app, DemoArgs& args) {
  CLI::App* cmd = app.add_subcommand(
      "demo",
      "The whole workflow on a built-in phantom: phantom, prepare, pre-dura pose, register, "
      "evaluate (landmarks and the whole brain), beside a registration from one sweep alone");
  cmd->add_option("--out", args.out, "output folder (created if missing)")->capture_default_str();
  cmd->add_option("--seed", args.seed, "phantom seed")->capture_default_str();
  return cmd;
}

int run_demo(const DemoArgs& args, std::ostream& out) {
  const workflow::Progress progress("demo");
  std::error_code ec;
  std::filesystem::create_directories(args.out, ec);
  BS_VERIFY(!ec, args.out.string() << ": cannot create the output folder: " << ec.message());
  const auto phantom = args.out / "phantom", model = args.out / "model",
             result = args.out / "result", one_sweep = args.out / "result_one_sweep",
             pose_file = args.out / workflow::pose_file_name;
  std::filesystem::remove_all(phantom, ec);  // generate_case wants a fresh folder

  std::ostringstream log;  // the stages' own summaries, shown after ours
  progress.stage("phantom 'standard' (neo-Hookean truth)");
  double t = progress.seconds();
  data_synth::CaseOptions co;
  co.out = phantom;
  co.progress = [&progress](const std::string& m) { progress.stage("phantom: " + m); };
  const data_synth::CaseSummary truth = data_synth::generate_case("standard", args.seed, co);
  const double t_phantom = progress.seconds() - t;

  t = progress.seconds();
  PrepareArgs pa;
  pa.labels = phantom / "preop" / "labels.nii.gz";
  pa.mra = phantom / "preop" / "mra.nii.gz";
  pa.mri = phantom / "preop" / "mri.nii.gz";
  pa.out = model;
  run_prepare(pa, log);
  const double t_prepare = progress.seconds() - t;

  // The surgical session: the navigation offset measured once on the sweep over the closed dura,
  // stored, and given to the registration of the sweep after opening.
  t = progress.seconds();
  PreDuraArgs pd;
  pd.model = model;
  pd.doppler = phantom / "intraop" / "predura" / "doppler.nii.gz";
  pd.out = pose_file;
  run_pre_dura(pd, log);
  const double t_pose = progress.seconds() - t;

  t = progress.seconds();
  RegisterArgs ra;
  ra.model = model;
  ra.doppler = phantom / "intraop" / "doppler.nii.gz";
  // No B-mode here: on the phantom the footprint rows currently cost accuracy (see README).
  ra.mri = phantom / "preop" / "mri.nii.gz";
  ra.pre_dura_pose = pose_file;
  ra.out = result;
  const workflow::RegisterOutcome two = workflow::register_and_write(ra, progress);
  const double t_register = progress.seconds() - t;

  // The same post-opening sweep alone (no pre-dura pose), for comparison.
  RegisterArgs ro = ra;
  ro.pre_dura_pose.reset();
  ro.mri.reset();
  ro.out = one_sweep;
  const workflow::RegisterOutcome one = workflow::register_and_write(ro, progress);

  std::string note;
  const bool brain = write_brain_points(phantom, 2000, note);
  auto evaluate_result = [&](const std::filesystem::path& res) {
    EvaluateArgs ea;
    ea.result = res;
    ea.landmarks_pre = phantom / "truth" / "landmarks_preop.csv";
    ea.landmarks_intra = phantom / "truth" / "landmarks_intraop.csv";
    ea.surface_pre = phantom / "truth" / "ventricles_preop.vtp";
    ea.surface_intra = phantom / "truth" / "ventricles_intraop.vtp";
    if (brain) {
      ea.brain_points_pre = phantom / "truth" / "brain_points_preop.csv";
      ea.brain_points_intra = phantom / "truth" / "brain_points_intraop.csv";
    }
    return evaluate(ea);
  };
  const nlohmann::json ev = evaluate_result(result), ev_one = evaluate_result(one_sweep);

  nlohmann::json report;
  std::ifstream(result / "report.json") >> report;
  out << std::fixed << std::setprecision(2);
  out << "brainshift demo: phantom 'standard' (seed " << args.seed << "), cortical shift "
      << truth.stats.max_cortical_shift << " mm max, " << truth.landmarks << " landmarks"
      << (brain ? ", 2000 truth points over the brain" : "") << "\n";
  out << "  time: phantom " << t_phantom << " s, prepare " << t_prepare << " s, pre-dura pose "
      << t_pose << " s, register " << t_register << " s (registration itself "
      << report["timing"]["registration"].get<double>() << " s, " << report["iterations"].get<int>()
      << " iterations, " << report["stop"].get<std::string>() << ")\n";
  out << "  two sweeps (pre-dura pose + after opening): " << errors_line(ev) << "; max deformation "
      << two.max_displacement_mm << " mm; shift corrected "
      << ev["shift_corrected_pct"].get<double>() << " %\n";
  nlohmann::json report_one;
  std::ifstream(one_sweep / "report.json") >> report_one;
  out << "  one sweep (after opening alone):            " << errors_line(ev_one)
      << "; max deformation " << one.max_displacement_mm << " mm; the pose moves the fixed base "
      << report_one["rigid"]["fixed_base_moved_mm"]["mean"].get<double>() << " mm\n";
  if (!brain) out << "  (no whole-brain figure: " << note << ")\n";
  out << "  outputs: " << result.string()
      << "/{report.json, evaluation.json, deformed.vtu, displacement.nii.gz, "
      << "preop_to_intraop.nrrd, intraop_to_preop.nrrd, warped_mri.nii.gz, uncertainty.nii.gz, "
         "overlay.png, overlay_uncertainty.png}; the one-sweep result in "
      << one_sweep.string() << "\n";
  out << "  inputs:  " << phantom.string() << " (phantom), " << model.string() << " (model), "
      << pose_file.string() << " (the stored pre-dura pose)\n";
  if (!two.result.converged)
    out << "  note: the registration stopped without meeting its convergence test ("
        << report["stop"].get<std::string>() << "); the result above is its last iterate\n";
  out << log.str();
  return 0;
}

}  // namespace brainshift::apps
