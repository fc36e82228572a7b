// The stored pre-dura pose (apps/workflow/pose_file.hpp): a pose file round-trips exactly, and
// every kind of bad file is a one-line error naming the file and the problem.
#include "expect_error.hpp"
#include "temp_folder.hpp"

#include "apps/workflow/pose_file.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <string>

namespace brainshift::workflow {
namespace {

using tests::expect_error;

/// A pose file's JSON as pose_json() writes it, without a model (the grid is not checked here).
nlohmann::json pose_doc(const Eigen::Isometry3d& t) {
  nlohmann::json m = nlohmann::json::array();
  for (int r = 0; r < 4; ++r)
    m.push_back({t.matrix()(r, 0), t.matrix()(r, 1), t.matrix()(r, 2), t.matrix()(r, 3)});
  return {{"format", pose_format},
          {"version", pose_version},
          {"model_from_intraop", m},
          {"pre_dura", {{"points", 71}, {"message", "measured"}}}};
}

std::filesystem::path write(const tests::TempFolder& dir, const std::string& text) {
  const auto p = dir / "pose.json";
  std::ofstream(p) << text;
  return p;
}

TEST(PoseFile, RoundTripsARigidTransformExactly) {
  const tests::TempFolder dir;
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.rotate(Eigen::AngleAxisd(0.2, Vector3d(1, 2, 3).normalized()));
  t.pretranslate(Vector3d(12.5, -3.25, 7.0));
  write_pose_file(dir / "pose.json", pose_doc(t));
  const StoredPose p = read_pose_file(dir / "pose.json");
  // JSON keeps doubles to the last bit (nlohmann writes 17 significant digits): exact.
  EXPECT_EQ((p.model_from_intraop.matrix() - t.matrix()).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ(p.pre_dura["points"], 71);
}

TEST(PoseFile, BadFilesAreOneLineErrorsNamingTheFileAndTheProblem) {
  const tests::TempFolder dir;
  const auto file = (dir / "pose.json").string();
  expect_error([&] { read_pose_file(dir / "absent.json"); }, {"absent.json", "cannot open"});
  expect_error([&] { read_pose_file(write(dir, "{ not json")); }, {file, "not valid JSON"});
  expect_error([&] { read_pose_file(write(dir, "[1, 2]")); }, {file, "not a brainshift pose"});
  nlohmann::json j = pose_doc(Eigen::Isometry3d::Identity());
  j["format"] = "brainshift-model";
  expect_error([&] { read_pose_file(write(dir, j.dump())); }, {file, "not a brainshift pose"});
  j = pose_doc(Eigen::Isometry3d::Identity());
  j["version"] = 2;
  expect_error([&] { read_pose_file(write(dir, j.dump())); }, {file, "version 2"});
  j.erase("version");
  expect_error([&] { read_pose_file(write(dir, j.dump())); }, {file, "version"});
  j = pose_doc(Eigen::Isometry3d::Identity());
  j.erase("model_from_intraop");
  expect_error([&] { read_pose_file(write(dir, j.dump())); }, {file, "missing key"});
  j = pose_doc(Eigen::Isometry3d::Identity());
  j["model_from_intraop"][1] = {0, 1, 0};
  expect_error([&] { read_pose_file(write(dir, j.dump())); }, {file, "row 1"});
  j = pose_doc(Eigen::Isometry3d::Identity());
  j["model_from_intraop"][2][2] = "one";
  expect_error([&] { read_pose_file(write(dir, j.dump())); }, {file, "(2,2)", "finite"});
  // A NaN cannot be written in JSON; nlohmann writes it as null, which is refused the same way.
  j["model_from_intraop"][2][2] = std::nan("");
  expect_error([&] { read_pose_file(write(dir, j.dump())); }, {file, "(2,2)", "finite"});
  j = pose_doc(Eigen::Isometry3d::Identity());
  j["model_from_intraop"][3][0] = 0.5;
  expect_error([&] { read_pose_file(write(dir, j.dump())); }, {file, "last row"});
  // A scaling (1.01) and a reflection (det −1) are not rigid.
  j = pose_doc(Eigen::Isometry3d::Identity());
  j["model_from_intraop"][0][0] = 1.01;
  expect_error([&] { read_pose_file(write(dir, j.dump())); }, {file, "not a rigid transform"});
  j["model_from_intraop"][0][0] = -1.0;
  expect_error([&] { read_pose_file(write(dir, j.dump())); }, {file, "not a rigid transform"});
  j = pose_doc(Eigen::Isometry3d::Identity());
  j["model_from_intraop"][0][3] = 2000.0;
  expect_error([&] { read_pose_file(write(dir, j.dump())); }, {file, "over 1 m"});
}

}  // namespace
}  // namespace brainshift::workflow
