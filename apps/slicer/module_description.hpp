#pragma once
/// @file
/// @brief 3D Slicer command-line modules (Slicer Execution Model): the module description that
/// an executable prints for `--xml`, and the parsing of the flags it declares.
///
/// Slicer scans each folder of its "Additional module paths", runs every executable there with
/// `--xml` and builds a module panel from the description (category, title, parameter groups).
/// On Apply it writes the chosen input nodes to temporary files (volumes as NRRD), runs the
/// executable with `--<longflag> <value>` for every parameter that has a value, reads
/// `<filter-progress>` tags from its stdout, and, when it exits with 0, loads the outputs from the
/// paths it gave. Format: Slicer/SlicerExecutionModel, ModuleDescriptionParser and
/// ModuleDescription.xsd (names and long flags: letters, digits and underscores only).

#include <functional>
#include <iosfwd>
#include <map>
#include <string>
#include <vector>

namespace brainshift::apps::slicer {

/// One parameter; its <name> is also its <longflag> (the executable takes `--name value`).
struct Parameter {
  std::string tag;    ///< image, transform, file, directory, double, integer, string-enumeration
  std::string name;   ///< letters, digits, _ (Slicer refuses others)
  std::string label;  ///< shown in the panel
  std::string description;  ///< tooltip
  std::string channel;      ///< "input" or "output" for data parameters, empty for values
  bool required = false;    ///< the executable refuses to run without it
  /// Extra XML attributes of the element, e.g. `type="label"`, `fileExtensions=".nrrd"`.
  std::string attributes;
  std::string default_value;           ///< <default>, empty for none
  std::vector<std::string> elements;   ///< the values of an enumeration
  std::string minimum, maximum, step;  ///< <constraints> of a number (all three or none)
};

/// A <parameters> group (a collapsible section of the panel).
struct ParameterGroup {
  std::string label;
  std::string description;
  bool advanced = false;  ///< collapsed by default
  std::vector<Parameter> parameters;
};

/// The whole <executable> description.
struct ModuleDescription {
  std::string category;  ///< module menu path, e.g. "Registration.Brain shift"
  std::string title;
  std::string description;
  std::string version;
  std::string documentation_url;
  std::string license;
  std::string contributor;
  std::string acknowledgements;
  std::vector<ParameterGroup> groups;
};

/// The XML Slicer reads (UTF-8, text escaped).
std::string to_xml(const ModuleDescription& module);

/// Values of the parameters given on the command line, by name (absent: not given).
using Values = std::map<std::string, std::string>;

/// Receives progress: what starts now and the fraction done (0…1).
using ProgressReport = std::function<void(const std::string& what, double fraction)>;

/// The main of a module executable. `--xml`: prints to_xml() and returns 0. Otherwise parses the
/// flags the description declares (`--help` lists them), prints Slicer's <filter-start>, runs
/// `body(values, progress)` and prints <filter-end>. `body` returns the exit code.
/// Errors (a bad flag, a missing required parameter, a brainshift::Error or other exception):
/// one line on stderr, "<executable>: error: <message>", exit code 1.
int run_module(int argc, char** argv, const std::string& executable,
               const ModuleDescription& module,
               const std::function<int(const Values&, const ProgressReport&)>& body);

}  // namespace brainshift::apps::slicer
