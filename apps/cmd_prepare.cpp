#include "cmd_prepare.hpp"

#include <CLI/CLI.hpp>

#include <ostream>

namespace brainshift::apps {

CLI::App* add_prepare_command(CLI::App& app, PrepareArgs& args) {
  CLI::App* c = app.add_subcommand(
      "prepare", "Pre-operative model: mesh, surface, vessels, scene (MODEL folder)");
  c->add_option("--labels", args.labels,
                "label volume: 0 background, 1 brain, 2 tumour, 3 ventricles")
      ->required();
  c->add_option("--mra", args.mra, "MR angiogram in the same frame")->required();
  c->add_option("--mri", args.mri, "pre-operative MRI (recorded to check later inputs)");
  c->add_option("--scene-options", args.scene_options,
                "JSON of scene keys and options merged over the default scene (README, "
                "\"The scene\"); an unknown key is an error naming it");
  c->add_option("--refine", args.mesh_refinement,
                "mesh refinement (1 ≈ 1.6k nodes on the phantom; node count grows ≈ r^2.7)")
      ->check(CLI::Range(0.25, 6.0));
  c->add_option("--surface-vertices", args.surface_vertices, "collision surface size")
      ->check(CLI::Range(20, 100000));
  c->add_option("--out", args.out, "MODEL folder to write")->required();
  return c;
}

int run_prepare(const PrepareArgs& args, std::ostream& out,
                const workflow::Progress::Sink& progress_sink) {
  const workflow::Progress progress("prepare", progress_sink);
  const workflow::PrepareResult r = workflow::prepare_model(args, progress);
  out << "prepared " << args.out.string() << ": " << r.nodes << " nodes, " << r.tets
      << " tetrahedra, " << r.surface_vertices << " surface vertices, " << r.fixed_nodes
      << " fixed nodes, " << r.vessel_branches << " vessel branches ("
      << static_cast<int>(r.vessel_length_mm) << " mm; " << r.vessel_points_snapped
      << " vessel points moved onto the mesh, " << r.vessel_points_dropped << " dropped) in "
      << progress.seconds() << " s\n";
  for (const std::string& w : r.warnings) out << "warning: " << w << '\n';
  return 0;
}

}  // namespace brainshift::apps
