#pragma once
/// @file
/// @brief `brainshift prepare`: the pre-operative model from a label volume and an MRA — mesh
/// (CGAL), decimated collision surface, fixed region, vessel skeleton, scene — written as a
/// MODEL folder (model_folder.hpp). Argument parsing over prepare_model()
/// (apps/workflow/prepare.hpp).

#include "apps/workflow/prepare.hpp"
#include "apps/workflow/progress.hpp"

#include <filesystem>
#include <iosfwd>

namespace CLI {
class App;
}  // namespace CLI

namespace brainshift::apps {

/// The flags of `brainshift prepare` (workflow/prepare.hpp).
using PrepareArgs = workflow::PrepareOptions;

CLI::App* add_prepare_command(CLI::App& app, PrepareArgs& args);

/// Builds and writes the model; prints a summary to `out` and progress to stderr (or to
/// `progress_sink` when given).
/// \throws brainshift::Error, one line, for any bad input (nothing is written then).
int run_prepare(const PrepareArgs& args, std::ostream& out,
                const workflow::Progress::Sink& progress_sink = {});

}  // namespace brainshift::apps
