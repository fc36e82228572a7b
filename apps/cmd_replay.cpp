#include "cmd_replay.hpp"

#include "apps/workflow/progress.hpp"

#include <CLI/CLI.hpp>

#include <iomanip>
#include <ostream>

namespace brainshift::apps {

CLI::App* add_replay_command(CLI::App& app, ReplayArgs& args) {
  CLI::App* c =
      app.add_subcommand("replay", "Register every frame of a recorded sequence, warm-started");
  c->add_option("--model", args.model, "MODEL folder from brainshift prepare")->required();
  c->add_option("--sequence", args.sequence, "folder with frame_*/doppler.nii.gz (+ bmode.nii.gz)")
      ->required();
  c->add_option("--out", args.out, "result folder RES")->required();
  c->add_option("--pre-dura", args.pre_dura,
                "power-Doppler volume of a sweep on the dura before it was opened: the navigation "
                "offset is measured on it once and kept for every frame (stored as "
                "RES/pre_dura_pose.json)");
  c->add_option("--pre-dura-pose", args.pre_dura_pose,
                "the same offset measured beforehand (brainshift pre-dura): no extraction")
      ->excludes("--pre-dura");
  c->add_option("--uncertainty", args.uncertainty,
                "predicted error (uncertainty.nii.gz, ~0.1-0.2 s a frame): every frame, only the "
                "last frame, or none")
      ->check(CLI::IsMember({"every", "last", "none"}));
  return c;
}

int run_replay(const ReplayArgs& args, std::ostream& out) {
  const workflow::Progress progress("replay");
  const workflow::ReplayResult r = workflow::replay_sequence(args, progress);
  out << std::fixed << std::setprecision(3) << r.frames << " frames: " << r.frames - r.failed
      << " registered (" << r.unconverged << " not converged), " << r.failed
      << " failed; latency median " << r.summary["latency_s"]["median"].get<double>() << " s, p95 "
      << r.summary["latency_s"]["p95"].get<double>() << " s, max "
      << r.summary["latency_s"]["max"].get<double>() << " s; results in " << args.out.string()
      << "\n";
  if (r.failed == static_cast<int>(r.frames)) return 1;
  return r.failed > 0 || r.unconverged > 0 ? 2 : 0;
}

}  // namespace brainshift::apps
