// brainshift: brain-shift compensation from the command line.
//
// Subcommands (each has --help):
//   brainshift demo [--out DIR] [--seed N]
//       The whole workflow on a built-in phantom (no data needed): phantom 'standard', prepare,
//       register, evaluate; prints time per stage, TRE before -> after and shift corrected.
//   brainshift prepare --labels L.nii.gz --mra A.nii.gz [--mri M.nii.gz]
//                      [--scene-options O.json] --out MODEL
//       Pre-operative model: mesh, collision surface, fixed region, vessel skeleton, scene.
//   brainshift register --model MODEL --doppler D.nii.gz [--bmode B.nii.gz] [--mri M.nii.gz]
//                       [--pre-dura P.nii.gz | --pre-dura-pose POSE.json]
//                       [--init rigid|identity] --out RES
//       One intra-operative registration: RES/{report.json, deformed.vtu, displacement.nii.gz,
//       preop_to_intraop.nrrd, intraop_to_preop.nrrd, warped_mri.nii.gz, uncertainty.nii.gz,
//       overlay.png[, overlay_uncertainty.png]}.
//   brainshift pre-dura --model MODEL --doppler P.nii.gz --out POSE.json
//       The navigation offset measured once on a sweep made on the closed dura, stored for
//       register / replay --pre-dura-pose (no second extraction).
//   brainshift replay --model MODEL --sequence DIR
//                     [--pre-dura P.nii.gz | --pre-dura-pose POSE.json] --out RES
//       Every DIR/frame_*/ in order, warm-started; latency summary in RES/replay.json.
//   brainshift serve --model MODEL [--mri M.nii.gz] [--pre-dura-pose POSE.json] --out DIR
//                    (--listen [PORT] | --connect HOST:PORT)
//       Registrations over OpenIGTLink: Doppler / BMode / PreDuraDoppler IMAGEs in; STATUS,
//       TRANSFORM IntraopToPreop, POLYDATA, IMAGE WarpedMRI, STRING BrainshiftReport out;
//       DIR/frame_NNNN/ as register's RES. Until SIGINT / SIGTERM.
//   brainshift evaluate --result RES --landmarks-pre A.csv --landmarks-intra B.csv
//                       [--surface-pre S.vtp --surface-intra T.vtp]
//       TRE before/after, shift corrected, Hausdorff percentiles; RES/evaluation.json.
//   brainshift reconstruct --sequence S.seq.mha [--calibration ImageToProbe.txt] [--spacing MM]
//                          --out V.nii.gz [--coverage C.nii.gz] [--report R.json]
//       A volume from a PLUS sequence of tracked frames (pixel nearest neighbour, hole filling).
//   brainshift export-dicom --volume RES/warped_mri.nii.gz [--like MRI_SERIES] --out DIR
//       A volume as a DICOM MR series (new series UID; patient and study of --like kept; marked
//       brain-shift corrected, not for diagnosis), for a navigation system to import.
//   brainshift phantom --case NAME [--seed N] [--vessels FILE.vtp] [--frames K] --out DIR
//       Synthetic phantom case with known truth (pre-op MRI/labels/MRA, intra-op Doppler/B-mode,
//       truth displacement and landmarks); an unknown NAME lists the valid ones.
//   brainshift bench [--quick] [--suite all|cases|sweeps] [--cases a,b] [--seed N] [--repeat N]
//   [--keep-work]
//                    --out DIR
//       Speed against error on the phantom cases (baselines rigid_only and prescribed_displacement)
//       and sweeps over mesh size, vessel sampling, compliance strategy, PGS tolerance and
//       constraint sets: DIR/{results.csv, results.json, results.md, pareto.png}.
//   brainshift extract vessels --image FILE --out SKELETON.vtp [--report REPORT.json] [--png
//   MIP.png]
//       One extraction alone, to check an input: the vessel skeleton of an MRA, CTA or power
//       Doppler (as prepare writes vessels.vtp), a report and a maximum-intensity projection.
//   brainshift extract footprint --bmode B.nii.gz [--probe-direction X,Y,Z] --out FOOTPRINT.vtp
//                                [--report REPORT.json]
//       The probe footprint of one B-mode volume (points, normals into the tissue), to check an
//       input before registering; the beam is estimated from the swept region unless given.
//   brainshift options [--markdown]
//       Every scene key, one a line: path, default, accepted values, what it does (the Markdown
//       form is docs/OPTIONS.md).
//   brainshift simulate --mesh brain.vtu --fixed fixed.csv --displace displace.csv
//                       [--gravity 0,0,-9810] [--linear] [--max-iterations 200]
//                       [--tolerance 1e-6] [--write-unconverged] --out result.vtu
//       Static corotational FEM under fixed nodes, prescribed displacements (mm) and gravity
//       (mm/s^2); writes the rest mesh with the point array 'displacement' (mm).
//
// Exit codes: 0 success; 1 bad input or any error (one line on stderr:
// "brainshift: error: <message>"); 2 the solve or registration did not converge (outputs are
// still written and say so; replay: some frames failed);
// command-line syntax errors use CLI11's codes (non-zero).
//
// Units: mm, kg, s (force mN, stress kPa); world frame RAS, mm.

#include "cmd_bench.hpp"
#include "cmd_demo.hpp"
#include "cmd_evaluate.hpp"
#include "cmd_export_dicom.hpp"
#include "cmd_extract.hpp"
#include "cmd_extract_footprint.hpp"
#include "cmd_options.hpp"
#include "cmd_phantom.hpp"
#include "cmd_pre_dura.hpp"
#include "cmd_prepare.hpp"
#include "cmd_reconstruct.hpp"
#include "cmd_register.hpp"
#include "cmd_replay.hpp"
#include "cmd_serve.hpp"
#include "cmd_simulate.hpp"

#include "apps/workflow/user_error.hpp"
#include "core/blas_threads.hpp"
#include "core/error.hpp"
#include "core/process_memory.hpp"
#include "imaging/io/output_guard.hpp"

#include <CLI/CLI.hpp>

#include <exception>
#include <iostream>

int main(int argc, char** argv) {
  namespace apps = brainshift::apps;
  CLI::App app{"brainshift: brain-shift compensation with a corotational FEM brain model",
               "brainshift"};
  app.require_subcommand(1);
  apps::SimulateArgs simulate_args;
  apps::DemoArgs demo_args;
  const CLI::App* simulate = apps::add_simulate_command(app, simulate_args);
  const CLI::App* demo = apps::add_demo_command(app, demo_args);
  apps::PhantomArgs phantom_args;
  const CLI::App* phantom = apps::add_phantom_command(app, phantom_args);
  apps::PrepareArgs prepare_args;
  const CLI::App* prepare = apps::add_prepare_command(app, prepare_args);
  apps::RegisterArgs register_args;
  const CLI::App* reg = apps::add_register_command(app, register_args);
  apps::PreDuraArgs pre_dura_args;
  const CLI::App* pre_dura = apps::add_pre_dura_command(app, pre_dura_args);
  apps::ReplayArgs replay_args;
  const CLI::App* replay = apps::add_replay_command(app, replay_args);
  apps::ServeArgs serve_args;
  const CLI::App* serve = apps::add_serve_command(app, serve_args);
  apps::EvaluateArgs evaluate_args;
  const CLI::App* evaluate = apps::add_evaluate_command(app, evaluate_args);
  apps::ExportDicomArgs export_dicom_args;
  const CLI::App* export_dicom = apps::add_export_dicom_command(app, export_dicom_args);
  apps::ReconstructArgs reconstruct_args;
  const CLI::App* reconstruct = apps::add_reconstruct_command(app, reconstruct_args);
  apps::OptionsArgs options_args;
  const CLI::App* options = apps::add_options_command(app, options_args);
  apps::BenchArgs bench_args;
  const CLI::App* bench = apps::add_bench_command(app, bench_args);
  // `extract` and its subcommands, one file each (cmd_extract*.cpp).
  CLI::App* extract = apps::add_extract_command(app);
  apps::ExtractVesselsArgs extract_vessels_args;
  const CLI::App* extract_vessels =
      apps::add_extract_vessels_command(*extract, extract_vessels_args);
  apps::ExtractFootprintArgs extract_footprint_args;
  const CLI::App* extract_footprint =
      apps::add_extract_footprint_command(*extract, extract_footprint_args);

  // A run ended by SIGINT / SIGTERM / SIGHUP leaves no temporary behind (`serve` handles them
  // itself, finishing the frame in progress).
  brainshift::imaging::remove_temporaries_on_signal();
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::cerr << "brainshift: error: " << e.what() << " (see brainshift --help)\n";
    return e.get_exit_code() != 0 ? e.get_exit_code() : 1;
  }

  // The intra-operative commands allocate and free volumes of tens of MB and end soon after:
  // reuse freed memory instead of faulting in fresh pages for each (core/process_memory.hpp).
  // Not for the long or heavy ones (bench, prepare), whose peak heap would be kept.
  // They also run their own two threads on small models: one BLAS thread (core/blas_threads.hpp).
  if (reg->parsed() || replay->parsed() || serve->parsed() || pre_dura->parsed() ||
      extract_vessels->parsed() || extract_footprint->parsed()) {
    (void)brainshift::core::keep_freed_memory_for_reuse();
    (void)brainshift::core::one_blas_thread_unless_set();
  }
  try {
    if (simulate->parsed()) return apps::run_simulate(simulate_args, std::cout);
    if (demo->parsed()) return apps::run_demo(demo_args, std::cout);
    if (phantom->parsed()) return apps::run_phantom(phantom_args, std::cout);
    if (prepare->parsed()) return apps::run_prepare(prepare_args, std::cout);
    if (reg->parsed()) return apps::run_register(register_args, std::cout);
    if (pre_dura->parsed()) return apps::run_pre_dura(pre_dura_args, std::cout);
    if (export_dicom->parsed()) return apps::run_export_dicom(export_dicom_args, std::cout);
    if (reconstruct->parsed()) return apps::run_reconstruct(reconstruct_args, std::cout);
    if (replay->parsed()) return apps::run_replay(replay_args, std::cout);
    if (serve->parsed()) return apps::run_serve(serve_args, std::cout);
    if (evaluate->parsed()) return apps::run_evaluate(evaluate_args, std::cout);
    if (bench->parsed()) return apps::run_bench(bench_args, std::cout);
    if (options->parsed()) return apps::run_options(options_args, std::cout);
    if (extract_vessels->parsed())
      return apps::run_extract_vessels(extract_vessels_args, std::cout);
    if (extract_footprint->parsed())
      return apps::run_extract_footprint(extract_footprint_args, std::cout);
  } catch (const std::exception& e) {  // one line, never the library's own text
    std::cerr << "brainshift: error: " << brainshift::workflow::user_message(e) << '\n';
    return 1;
  }
  return 1;  // unreachable: require_subcommand(1)
}
