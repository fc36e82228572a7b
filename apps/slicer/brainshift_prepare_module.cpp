// BrainshiftPrepare: `brainshift prepare` as a 3D Slicer command-line module.
//
//   BrainshiftPrepare --xml                       (the module description Slicer reads)
//   BrainshiftPrepare --labels L.nrrd --mra A.nrrd [--mri M.nrrd] --model MODEL_FOLDER
//                     [--refine 1] [--surfaceVertices 300]
//
// Builds the patient model (mesh, collision surface, vessel skeleton, compliance block) from a
// label volume and an MR angiogram — the same run_prepare() as the command line — into the
// folder Slicer gives. That folder must be new, empty or a previous brainshift model (it is
// replaced whole). Progress goes to stdout in Slicer's <filter-progress> tags; errors: one line
// on stderr naming the file, exit code 1, nothing written.

#include "../cmd_prepare.hpp"
#include "module_description.hpp"
#include "slicer_modules.hpp"

#include "core/error.hpp"

#include <filesystem>
#include <iostream>
#include <string>

int main(int argc, char** argv) {
  namespace slicer = brainshift::apps::slicer;
  return slicer::run_module(argc, argv, "BrainshiftPrepare", slicer::prepare_module(),
                            [](const slicer::Values& v, const slicer::ProgressReport& progress) {
                              brainshift::apps::PrepareArgs args;
                              args.labels = v.at("labels");
                              args.mra = v.at("mra");
                              if (v.count("mri")) args.mri = v.at("mri");
                              args.out = v.at("model");
                              args.mesh_refinement = std::stod(v.at("refine"));
                              args.surface_vertices = std::stoi(v.at("surfaceVertices"));
                              slicer::verify_replaceable_folder(args.out, "model.json");
                              // prepare reports 5 stages (read, mesh, vessels, write, factorise).
                              int stage = 0;
                              return brainshift::apps::run_prepare(
                                  args, std::cout, [&](const std::string& what, double) {
                                    progress(what, 0.9 * stage++ / 5.0);
                                  });
                            });
}
