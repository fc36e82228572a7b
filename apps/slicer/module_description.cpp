#include "module_description.hpp"

#include "core/error.hpp"
#include "imaging/io/output_guard.hpp"

#include <CLI/CLI.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <exception>
#include <iostream>
#include <sstream>

namespace brainshift::apps::slicer {
namespace {

/// Text for XML character data and attribute values.
std::string escape(const std::string& text) {
  std::string out;
  for (char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

/// Text inside Slicer's progress tags: Slicer cuts them out with `<tag>[^<]*</tag>` and does not
/// unescape, so angle brackets are replaced and line breaks flattened.
std::string progress_text(const std::string& text) {
  std::string out = text;
  for (char& c : out) {
    if (c == '<' || c == '>') c = '\'';
    if (c == '\n' || c == '\r') c = ' ';
  }
  return out;
}

void element(std::ostringstream& x, const char* indent, const char* tag, const std::string& value) {
  x << indent << '<' << tag << '>' << escape(value) << "</" << tag << ">\n";
}

void parameter_xml(std::ostringstream& x, const Parameter& p) {
  x << "    <" << p.tag;
  if (!p.attributes.empty()) x << ' ' << p.attributes;
  x << ">\n";
  element(x, "      ", "name", p.name);
  element(x, "      ", "longflag", p.name);
  element(x, "      ", "label", p.label);
  element(x, "      ", "description", p.description);
  if (!p.channel.empty()) element(x, "      ", "channel", p.channel);
  for (const auto& e : p.elements) element(x, "      ", "element", e);
  if (!p.default_value.empty()) element(x, "      ", "default", p.default_value);
  if (!p.minimum.empty()) {
    x << "      <constraints>\n";
    element(x, "        ", "minimum", p.minimum);
    element(x, "        ", "maximum", p.maximum);
    element(x, "        ", "step", p.step);
    x << "      </constraints>\n";
  }
  x << "    </" << p.tag << ">\n";
}

/// Slicer's progress tags on stdout, flushed at once (Slicer reads them while the module runs).
class FilterProgress {
 public:
  FilterProgress(std::string name, const std::string& comment)
      : m_name(std::move(name)), m_start(std::chrono::steady_clock::now()) {
    std::cout << "<filter-start><filter-name>" << m_name << "</filter-name><filter-comment>"
              << progress_text(comment) << "</filter-comment></filter-start>" << std::endl;
  }
  void report(const std::string& what, double fraction) const {
    char value[32];
    std::snprintf(value, sizeof value, "%.3f", std::clamp(fraction, 0.0, 1.0));
    std::cout << "<filter-comment>" << progress_text(what) << "</filter-comment>\n<filter-progress>"
              << value << "</filter-progress>" << std::endl;
  }
  void end() const {
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - m_start).count();
    std::cout << "<filter-progress>1</filter-progress>\n<filter-end><filter-name>" << m_name
              << "</filter-name><filter-time>" << seconds << "</filter-time></filter-end>"
              << std::endl;
  }

 private:
  std::string m_name;
  std::chrono::steady_clock::time_point m_start;
};

}  // namespace

std::string to_xml(const ModuleDescription& m) {
  std::ostringstream x;
  x << "<?xml version=\"1.0\" encoding=\"utf-8\"?>\n<executable>\n";
  element(x, "  ", "category", m.category);
  element(x, "  ", "title", m.title);
  element(x, "  ", "description", m.description);
  element(x, "  ", "version", m.version);
  element(x, "  ", "documentation-url", m.documentation_url);
  element(x, "  ", "license", m.license);
  element(x, "  ", "contributor", m.contributor);
  if (!m.acknowledgements.empty()) element(x, "  ", "acknowledgements", m.acknowledgements);
  for (const ParameterGroup& g : m.groups) {
    x << "  <parameters" << (g.advanced ? " advanced=\"true\"" : "") << ">\n";
    element(x, "    ", "label", g.label);
    element(x, "    ", "description", g.description);
    for (const Parameter& p : g.parameters) parameter_xml(x, p);
    x << "  </parameters>\n";
  }
  x << "</executable>\n";
  return x.str();
}

int run_module(int argc, char** argv, const std::string& executable,
               const ModuleDescription& module,
               const std::function<int(const Values&, const ProgressReport&)>& body) {
  // Slicer cancels a module with SIGTERM: no temporary output is left behind.
  imaging::remove_temporaries_on_signal();
  for (int a = 1; a < argc; ++a) {
    if (std::string(argv[a]) == "--xml") {
      std::cout << to_xml(module);
      return 0;
    }
  }
  CLI::App app{module.title + ": " + module.description, executable};
  const std::string xml_help = "print the Slicer module description (XML) and exit";
  app.add_flag("--xml", xml_help);
  std::map<std::string, std::string> given;
  for (const ParameterGroup& g : module.groups) {
    for (const Parameter& p : g.parameters) {
      CLI::Option* o = app.add_option("--" + p.name, given[p.name], p.label + ": " + p.description);
      if (p.required) o->required();
      if (p.tag == "double" || p.tag == "float") o->check(CLI::Number);
      if (p.tag == "integer") o->check(CLI::TypeValidator<int>("INTEGER"));
      if (p.tag == "double" && !p.minimum.empty())
        o->check(CLI::Range(std::stod(p.minimum), std::stod(p.maximum)));
      if (p.tag == "integer" && !p.minimum.empty())
        o->check(CLI::Range(std::stoi(p.minimum), std::stoi(p.maximum)));
      if (!p.elements.empty()) o->check(CLI::IsMember(p.elements));
    }
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::cerr << executable << ": error: " << e.what() << " (see " << executable << " --help)\n";
    return 1;
  }
  Values values;
  for (const ParameterGroup& g : module.groups) {
    for (const Parameter& p : g.parameters) {
      if (app.count("--" + p.name) > 0)
        values[p.name] = given[p.name];
      else if (!p.default_value.empty())
        values[p.name] = p.default_value;
    }
  }
  try {
    const FilterProgress progress(executable, module.title);
    const int code = body(values, [&progress](const std::string& what, double fraction) {
      progress.report(what, fraction);
    });
    progress.end();
    return code;
  } catch (const std::exception& e) {
    std::cerr << executable << ": error: " << e.what() << '\n';
    return 1;
  }
}

}  // namespace brainshift::apps::slicer
