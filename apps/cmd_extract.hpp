#pragma once
/// @file
/// @brief `brainshift extract`: one extraction alone, to check an input before registering or to
/// script. This file holds the `extract` command and its `vessels` subcommand:
///
///   brainshift extract vessels --image FILE --out SKELETON.vtp [--report REPORT.json] [--png
///   MIP.png]
///
/// The skeleton is the vessel graph of imaging::extract_vessels() (MRA, CTA or power Doppler),
/// written as `prepare` writes MODEL/vessels.vtp (imaging::write_skeleton_vtp: one polyline per
/// branch, world RAS mm, point array `radius`). The report (JSON) holds `branches`, `length_mm`,
/// `points`, `threshold` and `seconds` (the extraction alone), the threshold rule and levels,
/// header notes and warnings. The PNG is a maximum-intensity projection along the image axis
/// closest to the world's S axis, with the skeleton drawn over it in red.
///
/// Other extractions are further subcommands of `extract`, each in its own file, registered on
/// the App that add_extract_command() returns (e.g. `add_extract_footprint_command(CLI::App&
/// extract, ...)` in cmd_extract_footprint.{hpp,cpp}).

#include <filesystem>
#include <iosfwd>
#include <optional>

namespace CLI {
class App;
}  // namespace CLI

namespace brainshift::apps {

/// Arguments of `brainshift extract vessels`.
struct ExtractVesselsArgs {
  std::filesystem::path image;                  ///< MRA, CTA or power Doppler (one component)
  std::filesystem::path out;                    ///< skeleton .vtp
  std::optional<std::filesystem::path> report;  ///< JSON report
  std::optional<std::filesystem::path> png;     ///< maximum-intensity projection with the skeleton
  double prefilter_mm = 0.6;                    ///< Gaussian pre-filter σ, mm (0: none)
};

/// Registers the `extract` command (which needs one subcommand) on `app`.
/// @return the `extract` App, on which the extraction subcommands are registered.
CLI::App* add_extract_command(CLI::App& app);

/// Registers `vessels` on `extract`. `args` is not owned and must outlive `extract`.
CLI::App* add_extract_vessels_command(CLI::App& extract, ExtractVesselsArgs& args);

/// Extracts the vessels and writes the files (each atomically; all paths are checked before the
/// work starts); one summary line on `out`, warnings on stderr.
/// @return 0 on success.
/// \throws brainshift::Error, one line naming the file: unreadable or multi-component image, no
/// vessels in it (with the reason), an output folder that does not exist.
int run_extract_vessels(const ExtractVesselsArgs& args, std::ostream& out);

}  // namespace brainshift::apps
