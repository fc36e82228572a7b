#pragma once
/// @file
/// @brief `brainshift register`: one intra-operative registration against a prepared MODEL —
/// vessel points from the power Doppler, footprint from the B-mode, the constraint-based ICP,
/// and the outputs (report.json, deformed.vtu, displacement.nii.gz, preop_to_intraop.nrrd,
/// intraop_to_preop.nrrd, warped_mri.nii.gz, overlay.png; the fields in result_fields.hpp).
/// Argument parsing over the workflow library: register_and_write() (apps/workflow/register.hpp);
/// the session and report writers it uses are in apps/workflow/session.hpp and result_report.hpp.

#include "apps/workflow/register.hpp"
#include "apps/workflow/result_report.hpp"
#include "apps/workflow/session.hpp"

#include <iosfwd>

namespace CLI {
class App;
}  // namespace CLI

namespace brainshift::apps {

/// The flags of `brainshift register` (workflow/register.hpp).
using RegisterArgs = workflow::RegisterOptions;

CLI::App* add_register_command(CLI::App& app, RegisterArgs& args);
/// Runs register_and_write() and prints its one-line summary. @return 0 converged, 2 not.
int run_register(const RegisterArgs& args, std::ostream& out);

}  // namespace brainshift::apps
