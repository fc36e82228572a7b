#include "cmd_pre_dura.hpp"

#include "apps/workflow/pose_file.hpp"
#include "apps/workflow/progress.hpp"
#include "apps/workflow/session.hpp"
#include "imaging/io/atomic_write.hpp"

#include <CLI/CLI.hpp>

#include <iomanip>
#include <ostream>

namespace brainshift::apps {

CLI::App* add_pre_dura_command(CLI::App& app, PreDuraArgs& args) {
  CLI::App* c = app.add_subcommand(
      "pre-dura",
      "Measure the navigation offset once on a sweep made before the dura was opened, and store "
      "it for register / replay --pre-dura-pose");
  c->add_option("--model", args.model, "MODEL folder from brainshift prepare")->required();
  c->add_option("--doppler", args.doppler,
                "power-Doppler volume of the sweep on the closed dura (no shift yet)")
      ->required();
  c->add_option("--out", args.out, "pose file to write (JSON, e.g. pre_dura_pose.json)")
      ->required();
  return c;
}

int run_pre_dura(const PreDuraArgs& args, std::ostream& out) {
  const workflow::Progress progress("pre-dura");
  imaging::verify_writable(args.out);  // before the model loads and the sweep is extracted
  progress.stage("loading the model " + args.model.string());
  const workflow::Session s = workflow::open_session(args.model);
  progress.stage("the navigation offset from the pre-dura sweep " + args.doppler.string());
  nlohmann::json report;
  const Eigen::Isometry3d pose =
      workflow::pose_from_pre_dura(s, args.doppler, s.loaded.scene.options, report);
  report["source"] = "measured";
  workflow::write_pose_file(args.out, workflow::pose_json(s, pose, report));
  out << std::fixed << std::setprecision(2) << "pre-dura pose from " << report.value("points", 0)
      << " vessel points: " << report["translation_mm"].get<double>() << " mm, "
      << report["rotation_deg"].get<double>() << " deg (" << report["message"].get<std::string>()
      << "); written to " << args.out.string() << " in " << progress.seconds() << " s\n";
  return 0;
}

}  // namespace brainshift::apps
