#include "cmd_phantom.hpp"

#include "core/error.hpp"
#include "data_synth/cases/label_case.hpp"
#include "data_synth/cases/phantom_case.hpp"

#include <CLI/CLI.hpp>

#include <cmath>
#include <iostream>

namespace brainshift::apps {

CLI::App* add_phantom_command(CLI::App& app, PhantomArgs& args) {
  std::string names;
  for (const std::string& n : data_synth::case_names()) names += (names.empty() ? "" : ", ") + n;
  CLI::App* cmd = app.add_subcommand(
      "phantom", "Synthetic phantom case with known truth (images, landmarks, displacement)");
  cmd->add_option("--case", args.case_name,
                  "Case name: " + names +
                      " (required without --labels; with it, the recipe, default standard)");
  cmd->add_option(
      "--labels", args.labels,
      "Label volume (0 background, 1 brain, 2 tumour, 3 ventricles): the case on its brain");
  cmd->add_option(
         "--tumour", args.tumour,
         "With --labels: tumour X,Y,Z,RADIUS (mm, world RAS; default: the labels' tumour, else "
         "30 mm beneath the craniotomy, radius 10 mm)")
      ->delimiter(',')
      ->expected(4);
  cmd->add_option(
         "--craniotomy", args.craniotomy,
         "With --labels: craniotomy centre X,Y,Z near the brain surface (mm, world RAS; default: "
         "the upper convexity)")
      ->delimiter(',')
      ->expected(3);
  cmd->add_option("--seed", args.seed, "Seed of the vessels and all noise")->capture_default_str();
  cmd->add_option("--vessels", args.vessels,
                  "User vessel tree (.vtp polylines, optional 'radius' array, mm), scaled and "
                  "placed into the phantom instead of the synthetic trees");
  cmd->add_option("--frames", args.frames,
                  "Also write K intra-operative frames (intraop/frame_000 ...) as the CSF drains")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd->add_option("--out", args.out, "Output folder (must not exist, or be empty)")->required();
  return cmd;
}

namespace {

data_synth::CaseSummary generate(const PhantomArgs& args, const data_synth::CaseOptions& options) {
  if (!args.labels) {
    BS_VERIFY(args.tumour.empty() && args.craniotomy.empty(),
              "--tumour and --craniotomy need --labels FILE");
    BS_VERIFY(!args.case_name.empty(), "--case NAME is required without --labels");
    return data_synth::generate_case(args.case_name, args.seed, options);
  }
  data_synth::LabelCaseRequest r;
  r.labels = *args.labels;
  r.case_name = args.case_name.empty() ? "standard" : args.case_name;
  r.seed = args.seed;
  if (!args.tumour.empty()) {
    BS_VERIFY(args.tumour.size() == 4,
              "--tumour needs X,Y,Z,RADIUS, got " << args.tumour.size() << " values");
    r.tumour_centre = Vector3d(args.tumour[0], args.tumour[1], args.tumour[2]);
    BS_VERIFY(std::isfinite(args.tumour[3]) && args.tumour[3] > 0.0,
              "--tumour radius " << args.tumour[3] << " mm must be positive");
    r.tumour_radius = args.tumour[3];
  }
  if (!args.craniotomy.empty()) {
    BS_VERIFY(args.craniotomy.size() == 3,
              "--craniotomy needs X,Y,Z, got " << args.craniotomy.size() << " values");
    r.craniotomy = Vector3d(args.craniotomy[0], args.craniotomy[1], args.craniotomy[2]);
  }
  return data_synth::generate_label_case(r, options);
}

}  // namespace

int run_phantom(const PhantomArgs& args, std::ostream& out) {
  data_synth::CaseOptions options;
  options.out = args.out;
  options.frames = args.frames;
  options.user_vessels = args.vessels;
  options.progress = [](const std::string& step) {
    std::cerr << "brainshift phantom: " << step << "...\n";
  };
  const data_synth::CaseSummary s = generate(args, options);
  out << "brainshift phantom: case " << s.name
      << (args.labels ? " on " + args.labels->string() : "") << ", seed " << s.seed << " -> "
      << args.out.string() << '\n'
      << "  truth solve:          " << data_synth::to_string(s.solver_status) << " ("
      << s.solver_message << ")\n"
      << "  max cortical shift:   " << s.stats.max_cortical_shift << " mm\n"
      << "  mean cortical shift:  " << s.stats.mean_cortical_shift << " mm (under the craniotomy)\n"
      << "  mean landmark shift:  " << s.stats.mean_landmark_shift << " mm over " << s.landmarks
      << " landmarks (" << s.vessel_landmarks << " vessel bifurcations)\n"
      << "  frames:               " << s.frames.size() << '\n'
      << "  wall time:            " << s.seconds << " s\n";
  if (s.solver_status != data_synth::TledStatus::CONVERGED) {
    std::cerr << "brainshift: error: the truth solve did not converge: " << s.solver_message
              << " (the case was written; see case.json)\n";
    return 2;
  }
  return 0;
}

}  // namespace brainshift::apps
