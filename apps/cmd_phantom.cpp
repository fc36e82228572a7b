#include "cmd_phantom.hpp"

#include <CLI/CLI.hpp>

#include <iostream>

#include "data_synth/cases/phantom_case.hpp"

namespace brainshift::apps {

CLI::App* add_phantom_command(CLI::App& app, PhantomArgs& args) {
  std::string names;
  for (const std::string& n : data_synth::case_names()) names += (names.empty() ? "" : ", ") + n;
  CLI::App* cmd = app.add_subcommand(
      "phantom", "Synthetic phantom case with known truth (images, landmarks, displacement)");
  cmd->add_option("--case", args.case_name, "Case name: " + names)->required();
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

int run_phantom(const PhantomArgs& args, std::ostream& out) {
  data_synth::CaseOptions options;
  options.out = args.out;
  options.frames = args.frames;
  options.user_vessels = args.vessels;
  options.progress = [](const std::string& step) {
    std::cerr << "brainshift phantom: " << step << "...\n";
  };
  const data_synth::CaseSummary s = data_synth::generate_case(args.case_name, args.seed, options);
  out << "brainshift phantom: case " << s.name << ", seed " << s.seed << " -> " << args.out.string()
      << '\n'
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
