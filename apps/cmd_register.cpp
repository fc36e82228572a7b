#include "cmd_register.hpp"

#include "apps/workflow/progress.hpp"

#include <CLI/CLI.hpp>

#include <iostream>

namespace brainshift::apps {

CLI::App* add_register_command(CLI::App& app, RegisterArgs& args) {
  CLI::App* c =
      app.add_subcommand("register", "Register a prepared model to intra-operative ultrasound");
  c->add_option("--model", args.model, "MODEL folder from brainshift prepare")->required();
  c->add_option("--doppler", args.doppler, "power-Doppler volume (vessels)")->required();
  c->add_option("--bmode", args.bmode,
                "B-mode volume (probe footprint; the beam is estimated from the swept region, any "
                "grid orientation)");
  c->add_option("--mri", args.mri, "pre-operative MRI to warp (same grid as the model's labels)");
  c->add_option("--pre-dura", args.pre_dura,
                "power-Doppler volume of a sweep on the dura before it was opened: the navigation "
                "offset is measured from it, so the sag is not mistaken for a pose (stored as "
                "RES/pre_dura_pose.json)");
  c->add_option("--pre-dura-pose", args.pre_dura_pose,
                "the same offset measured beforehand (brainshift pre-dura, or a previous run's "
                "RES/pre_dura_pose.json): no second extraction")
      ->excludes("--pre-dura");
  c->add_option("--landmarks", args.landmarks,
                "landmark pairs to register on as well: one two-volume MNI .tag (MRI set first) "
                "or two files PRE INTRA (CSV id,x,y,z RAS mm, .tag, Slicer .mrk.json or .fcsv), "
                "paired by id")
      ->expected(1, 2);
  c->add_option("--init", args.init, "rigid start: rigid or identity (default: the scene's)")
      ->check(CLI::IsMember({"rigid", "identity"}));
  c->add_option("--out", args.out, "result folder RES")->required();
  return c;
}

int run_register(const RegisterArgs& args, std::ostream& out) {
  const workflow::Progress progress("register");
  const workflow::RegisterOutcome o = workflow::register_and_write(args, progress);
  const constraints::RegistrationResult& r = o.result;
  out << "registered in " << r.iterations << " iterations (" << r.stop_reason << "); registration "
      << r.seconds.total << " s, total " << progress.seconds() << " s; max displacement "
      << o.max_displacement_mm << " mm; results in " << args.out.string() << "\n";
  if (!o.fixed_base_note.empty())
    std::cerr << "brainshift register: note: " << o.fixed_base_note << "\n";
  if (r.converged) return 0;
  std::cerr << "brainshift register: did not converge: " << r.stop_reason
            << " (results written; see report.json)\n";
  return 2;
}

}  // namespace brainshift::apps
