// The MODEL folder's manifest (apps/workflow/model_folder.cpp) read as hostile input (issue 36
// items 1-2): every bad model.json is one line naming the file and the field, with no JSON
// library text, and a grid too large for its result fields is refused before anything is
// allocated on it.
#include "expect_error.hpp"
#include "temp_folder.hpp"

#include "apps/workflow/model_folder.hpp"

#include <gtest/gtest.h>

#include <fstream>
#include <string>

namespace brainshift::workflow {
namespace {

using tests::expect_error;

const std::string head = R"({"format": "brainshift-model", "version": 1, )";
const std::string good_grid =
    R"("preop_grid": {"size": [4, 4, 4], "spacing_mm": [1, 1, 1], "origin_mm": [0, 0, 0], )"
    R"("direction": [[1, 0, 0], [0, 1, 0], [0, 0, 1]]}})";

/// load_model() on a folder holding `manifest` as model.json alone; its error message.
std::string error_of(const tests::TempFolder& dir, const std::string& manifest) {
  std::ofstream(dir / "model.json") << manifest;
  try {
    (void)load_model(dir.path());
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(ModelFolder, HostileManifestsAreOneLineErrorsWithoutLibraryText) {
  const tests::TempFolder dir;
  struct Case {
    std::string manifest, expected;
  };
  const Case cases[] = {
      {"{not json", "unreadable manifest (not valid JSON at byte"},
      {"[1, 2]", "not a brainshift model manifest (not a JSON object)"},
      {R"({"format": 5})", "not a brainshift model (format '')"},
      {R"({"format": "brainshift-model", "version": "one"})", "model version 0"},
      {head + R"("preop_grid": {"size": [4, 4]}})", "bad 'preop_grid'"},
      {head + R"("preop_grid": {"size": [4, 4, 4], "spacing_mm": [1, 0, 1], )"
              R"("origin_mm": [0, 0, 0], "direction": [[1, 0, 0], [0, 1, 0], [0, 0, 1]]}})",
       "spacing"},
      {head + R"("preop_grid": {"size": [100000, 100000, 100000], "spacing_mm": [1, 1, 1], )"
              R"("origin_mm": [0, 0, 0], "direction": [[1, 0, 0], [0, 1, 0], [0, 0, 1]]}})",
       "BRAINSHIFT_MAX_VOLUME_GB"},
      // A valid manifest gets as far as the scene it needs.
      {head + good_grid, "scene.json: cannot open"},
  };
  for (const Case& c : cases) {
    const std::string message = error_of(dir, c.manifest);
    SCOPED_TRACE(c.manifest);
    EXPECT_NE(message.find(c.expected), std::string::npos) << message;
    const bool scene = c.expected.find("scene.json") != std::string::npos;
    EXPECT_NE(message.find(scene ? "scene.json" : "model.json"), std::string::npos)
        << message;  // names the file
    EXPECT_EQ(message.find("json.exception"), std::string::npos) << message;
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
    EXPECT_LE(message.size(), 200U + dir.path().string().size()) << message;
  }
}

}  // namespace
}  // namespace brainshift::workflow
