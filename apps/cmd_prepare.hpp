#pragma once
/// @file
/// @brief `brainshift prepare`: the pre-operative model from a label volume and an MRA — mesh
/// (CGAL), decimated collision surface, fixed region, vessel skeleton, scene — written as a
/// MODEL folder (model_folder.hpp). Wiring only.

#include "apps/workflow/progress.hpp"

#include <filesystem>
#include <iosfwd>
#include <optional>

namespace CLI {
class App;
}  // namespace CLI

namespace brainshift::apps {

struct PrepareArgs {
  std::filesystem::path labels;                        ///< 0 bg, 1 brain, 2 tumour, 3 ventricles
  std::filesystem::path mra;                           ///< MR angiogram, same patient and frame
  std::optional<std::filesystem::path> mri;            ///< recorded in the manifest (grid, hash)
  std::optional<std::filesystem::path> scene_options;  ///< JSON merged over the default scene
  std::filesystem::path out;                           ///< MODEL folder
  double mesh_refinement = 1.0;  ///< 1 ≈ 1.6k nodes (phantom); grows ≈ r^2.7
  int surface_vertices = 300;    ///< decimated collision surface
};

CLI::App* add_prepare_command(CLI::App& app, PrepareArgs& args);

/// Builds and writes the model; prints a summary to `out` and progress to stderr (or to
/// `progress_sink` when given).
/// \throws brainshift::Error, one line, for any bad input (nothing is written then).
int run_prepare(const PrepareArgs& args, std::ostream& out,
                const Progress::Sink& progress_sink = {});

}  // namespace brainshift::apps
