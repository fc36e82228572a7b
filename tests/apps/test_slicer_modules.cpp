// The Slicer module executables describe themselves as Slicer expects (`--xml`: a Slicer
// Execution Model description, parsed here with VTK's XML parser) and declare exactly the flags
// they accept (`--help`). Running them is tested in test_slicer_workflow.cpp.

#include "test_slicer_helpers.hpp"

#include <gtest/gtest.h>

#include <regex>
#include <set>
#include <string>

namespace brainshift {
namespace {

using tests::XmlModule;
using tests::XmlParameter;

/// Slicer's parser refuses names and long flags other than identifiers (ModuleDescriptionParser).
bool valid_identifier(const std::string& s) {
  return std::regex_match(s, std::regex("[A-Za-z_][A-Za-z0-9_]*"));
}

class SlicerModule : public ::testing::TestWithParam<const char*> {};

TEST_P(SlicerModule, XmlHasTheModuleFieldsAndEveryParameterIsNamedLabelledAndFlagged) {
  const tests::TempFolder dir;
  const XmlModule m = tests::module_xml(dir, GetParam());
  ASSERT_FALSE(m.fields.empty());
  EXPECT_EQ(m.fields.at("category"), "Registration.Brain shift");
  for (const char* f :
       {"title", "description", "version", "documentation-url", "license", "contributor"}) {
    ASSERT_TRUE(m.fields.count(f)) << f;
    EXPECT_FALSE(m.fields.at(f).empty()) << f;
  }
  ASSERT_FALSE(m.groups.empty());
  std::set<std::string> names;
  for (const auto& g : m.groups) {
    EXPECT_FALSE(g.label.empty());
    EXPECT_FALSE(g.description.empty()) << g.label;
    for (const XmlParameter& p : g.parameters) {
      SCOPED_TRACE(p.name);
      EXPECT_TRUE(valid_identifier(p.name));
      EXPECT_FALSE(p.label.empty());
      EXPECT_FALSE(p.description.empty());
      EXPECT_TRUE(p.longflag.empty() != p.index.empty()) << "a longflag or an index, not both";
      if (!p.longflag.empty()) {
        EXPECT_TRUE(valid_identifier(p.longflag));
      }
      EXPECT_TRUE(names.insert(p.name).second) << "duplicate name";
      if (p.tag == "image" || p.tag == "transform" || p.tag == "file" || p.tag == "directory") {
        EXPECT_TRUE(p.channel == "input" || p.channel == "output") << p.channel;
      }
    }
  }
}

TEST_P(SlicerModule, DeclaresEveryFlagTheExecutableAcceptsAndNoOther) {
  const tests::TempFolder dir;
  const XmlModule m = tests::module_xml(dir, GetParam());
  std::set<std::string> declared;
  for (const auto& g : m.groups)
    for (const auto& p : g.parameters) declared.insert(p.longflag);
  const CliRun help = tests::run_exe(dir, tests::slicer_module(GetParam()), "--help");
  ASSERT_EQ(help.exit_code, 0) << help.err;
  std::set<std::string> accepted;
  const std::regex flag("--([A-Za-z_][A-Za-z0-9_]*)");
  for (std::sregex_iterator it(help.out.begin(), help.out.end(), flag), end; it != end; ++it)
    accepted.insert((*it)[1]);
  accepted.erase("help");  // CLI11's own
  accepted.erase("xml");   // Slicer's query for the description
  EXPECT_EQ(declared, accepted) << help.out;
}

INSTANTIATE_TEST_SUITE_P(Modules, SlicerModule,
                         ::testing::Values("BrainshiftPrepare", "BrainshiftRegister"));

/// tag, channel and (for outputs Slicer must read back) the file extension of one parameter.
void expect_parameter(const std::map<std::string, XmlParameter>& ps, const std::string& name,
                      const std::string& tag, const std::string& channel,
                      const std::string& extensions = "") {
  SCOPED_TRACE(name);
  ASSERT_TRUE(ps.count(name));
  const XmlParameter& p = ps.at(name);
  EXPECT_EQ(p.tag, tag);
  EXPECT_EQ(p.channel, channel);
  if (!extensions.empty()) {
    ASSERT_TRUE(p.attributes.count("fileExtensions"));
    EXPECT_EQ(p.attributes.at("fileExtensions"), extensions);
  }
}

TEST(SlicerModules, PrepareTakesLabelsMraAndMriAndWritesAModelFolder) {
  const tests::TempFolder dir;
  const auto ps = tests::parameters_by_name(tests::module_xml(dir, "BrainshiftPrepare"));
  expect_parameter(ps, "labels", "image", "input");
  EXPECT_EQ(ps.at("labels").attributes.at("type"), "label");
  expect_parameter(ps, "mra", "image", "input");
  expect_parameter(ps, "mri", "image", "input");
  expect_parameter(ps, "model", "directory", "output");
}

TEST(SlicerModules, RegisterTakesTheModelAndUltrasoundAndWritesImageTransformsAndReport) {
  const tests::TempFolder dir;
  const auto ps = tests::parameters_by_name(tests::module_xml(dir, "BrainshiftRegister"));
  expect_parameter(ps, "model", "directory", "input");
  expect_parameter(ps, "doppler", "image", "input");
  expect_parameter(ps, "bmode", "image", "input");
  expect_parameter(ps, "preDura", "image", "input");
  expect_parameter(ps, "preopMRI", "image", "input");
  expect_parameter(ps, "warpedMRI", "image", "output");
  expect_parameter(ps, "preopToIntraop", "transform", "output", ".nrrd");
  expect_parameter(ps, "intraopToPreop", "transform", "output", ".nrrd");
  expect_parameter(ps, "reportFile", "file", "output");
}

TEST(SlicerModules, AMissingRequiredFlagIsOneErrorLineAndExitCodeOne) {
  const tests::TempFolder dir;
  const CliRun r =
      tests::run_exe(dir, tests::slicer_module("BrainshiftRegister"), "--doppler x.nrrd");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_EQ(r.err.rfind("BrainshiftRegister: error: ", 0), 0U) << r.err;
  EXPECT_NE(r.err.find("--model"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace brainshift
