#pragma once
/// @file
/// @brief `brainshift extract footprint --bmode FILE [--probe-direction X,Y,Z] --out FOOTPRINT.vtp
/// [--report REPORT.json]`: the probe footprint of one B-mode volume, to check an input before
/// registering. FOOTPRINT.vtp holds the points (world RAS mm) and the point-data array `normals`
/// (unit, into the tissue); REPORT.json holds points, probe_direction, direction_source
/// (given/estimated), contrast, width_mm, seconds and warnings (see intraop_footprint.hpp).
/// No contact band is an error naming the file; a weak footprint is a warning (report, stderr).

#include <filesystem>
#include <iosfwd>
#include <optional>
#include <string>

namespace CLI {
class App;
}  // namespace CLI

namespace brainshift::apps {

struct ExtractFootprintArgs {
  std::filesystem::path bmode;
  std::optional<std::string>
      probe_direction;  ///< "X,Y,Z", world RAS, from the probe into the tissue
  std::filesystem::path out;
  std::optional<std::filesystem::path> report;
};

/// Adds `footprint` under the `extract` command.
CLI::App* add_extract_footprint_command(CLI::App& extract, ExtractFootprintArgs& args);
/// Runs it: 0 on success (warnings included), throws brainshift::Error otherwise.
int run_extract_footprint(const ExtractFootprintArgs& args, std::ostream& out);

}  // namespace brainshift::apps
