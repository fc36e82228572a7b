#pragma once
/// @file
/// @brief Driving the Slicer module executables (build/slicer_modules/) from tests: running them,
/// and reading the module description they print for `--xml` with VTK's XML parser into plain
/// structs.

#include "cli_helpers.hpp"

#include <gtest/gtest.h>
#include <vtkSmartPointer.h>
#include <vtkXMLDataElement.h>
#include <vtkXMLUtilities.h>

#include <cstdlib>
#include <filesystem>
#include <map>
#include <regex>
#include <set>
#include <string>
#include <sys/wait.h>
#include <vector>

namespace brainshift::tests {

using ::brainshift::run_exe;  // cli_helpers.hpp: any executable, output captured

inline std::filesystem::path slicer_module(const std::string& name) {
  return std::filesystem::path(BS_SLICER_MODULES_DIR) / name;
}

/// One parameter of a module description, as Slicer's parser would see it.
struct XmlParameter {
  std::string tag, name, longflag, index, label, description, channel;
  std::map<std::string, std::string> attributes;
};
struct XmlGroup {
  std::string label, description;
  std::vector<XmlParameter> parameters;
};
struct XmlModule {
  std::map<std::string, std::string> fields;  ///< category, title, description, version, …
  std::vector<XmlGroup> groups;
};

inline std::string trimmed(const char* text) {
  if (!text) return {};
  const std::string s = text;
  const auto a = s.find_first_not_of(" \t\r\n");
  if (a == std::string::npos) return {};
  return s.substr(a, s.find_last_not_of(" \t\r\n") - a + 1);
}

/// Parses the XML; an empty `fields` map means it did not parse (with a failure recorded).
inline XmlModule parse_module_xml(const std::string& xml) {
  XmlModule m;
  vtkSmartPointer<vtkXMLDataElement> root;
  root.TakeReference(vtkXMLUtilities::ReadElementFromString(xml.c_str()));
  if (!root) {
    ADD_FAILURE() << "the module description does not parse as XML:\n" << xml;
    return m;
  }
  EXPECT_STREQ(root->GetName(), "executable");
  for (int i = 0; i < root->GetNumberOfNestedElements(); ++i) {
    vtkXMLDataElement* e = root->GetNestedElement(i);
    const std::string tag = e->GetName();
    if (tag != "parameters") {
      m.fields[tag] = trimmed(e->GetCharacterData());
      continue;
    }
    XmlGroup g;
    for (int j = 0; j < e->GetNumberOfNestedElements(); ++j) {
      vtkXMLDataElement* p = e->GetNestedElement(j);
      const std::string ptag = p->GetName();
      if (ptag == "label")
        g.label = trimmed(p->GetCharacterData());
      else if (ptag == "description")
        g.description = trimmed(p->GetCharacterData());
      else {
        XmlParameter par;
        par.tag = ptag;
        for (int a = 0; a < p->GetNumberOfAttributes(); ++a)
          par.attributes[p->GetAttributeName(a)] = p->GetAttributeValue(a);
        for (int k = 0; k < p->GetNumberOfNestedElements(); ++k) {
          vtkXMLDataElement* c = p->GetNestedElement(k);
          const std::string ctag = c->GetName();
          const std::string value = trimmed(c->GetCharacterData());
          if (ctag == "name")
            par.name = value;
          else if (ctag == "longflag")
            par.longflag = value;
          else if (ctag == "index")
            par.index = value;
          else if (ctag == "label")
            par.label = value;
          else if (ctag == "description")
            par.description = value;
          else if (ctag == "channel")
            par.channel = value;
        }
        g.parameters.push_back(par);
      }
    }
    m.groups.push_back(g);
  }
  return m;
}

/// The module's description, from running it with --xml.
inline XmlModule module_xml(const TempFolder& dir, const std::string& module) {
  const CliRun r = run_exe(dir, slicer_module(module), "--xml");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(r.err.empty()) << r.err;
  return parse_module_xml(r.out);
}

/// Every parameter of a description, by name.
inline std::map<std::string, XmlParameter> parameters_by_name(const XmlModule& m) {
  std::map<std::string, XmlParameter> out;
  for (const auto& g : m.groups)
    for (const auto& p : g.parameters) out[p.name] = p;
  return out;
}

/// The command line Slicer would build: `--<longflag> <value>` for each parameter given a value.
inline std::string slicer_command_line(const XmlModule& m,
                                       const std::map<std::string, std::filesystem::path>& values) {
  std::string args;
  for (const auto& g : m.groups)
    for (const auto& p : g.parameters) {
      const auto it = values.find(p.name);
      if (it == values.end()) continue;
      args += " --" + p.longflag + " " + q(it->second);
    }
  return args;
}

}  // namespace brainshift::tests
