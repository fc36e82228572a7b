// Landmark files as users have them (imaging/io/landmark_files.hpp): the same three landmarks
// written by hand in each format (text as MNI's tag writer, Slicer 5's markups writer and Slicer
// 4's fiducial writer lay it out — not by our writer) read back to the same RAS positions;
// RESECT's 22 real tag files against the per-case summary shipped with them (computed by
// another program); bad files of each kind give one line naming the file.
#include "expect_error.hpp"
#include "temp_folder.hpp"
#include "tests/config.hpp"

#include "imaging/io/landmark_files.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>

namespace brainshift::imaging {
namespace {

using tests::expect_error;

std::filesystem::path write_landmark_text(const tests::TempFolder& dir, const std::string& name,
                                          const std::string& text) {
  const auto path = dir / name;
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

/// The truth: ids and RAS positions (mm) every file below encodes.
Landmarks truth() {
  Landmarks l;
  l.ids = {"1", "2", "3"};
  l.points.resize(3, 3);
  l.points << 50.164402, -31.719656, 34.845306,  //
      -44.5, 31.25, -29.970621,                  //
      0.125, 0, 1e-3;
  return l;
}

/// Exact equality: every format carries the same decimal text, and LPS ↔ RAS is a sign flip.
void expect_same(const Landmarks& got, const Landmarks& want, const std::string& what) {
  ASSERT_EQ(got.ids, want.ids) << what;
  ASSERT_EQ(got.points.rows(), want.points.rows()) << what;
  EXPECT_LE((got.points - want.points).cwiseAbs().maxCoeff(), 1e-12) << what;
}

TEST(LandmarkFiles, TheSamePointsFromEveryFormat) {
  const tests::TempFolder dir;
  const Landmarks t = truth();
  expect_same(
      read_landmark_file(write_landmark_text(dir, "l.csv",
                                             "id,x,y,z\n1,50.164402,-31.719656,34.845306\n"
                                             "2,-44.5,31.25,-29.970621\n3,0.125,0,0.001\n")),
      t, "csv");
  // A two-volume tag file: the first set is t, the second t + (1, 2, 3); one line carries
  // weight, structure id and patient id, as the format allows.
  const std::string tag =
      "MNI Tag Point File\nVolumes = 2;\n% a comment\n\nPoints =\n"
      " 50.164402 -31.719656 34.845306 51.164402 -29.719656 37.845306 \"\"\n"
      " -44.5 31.25 -29.970621 -43.5 33.25 -26.970621 1 0 0 \"\"\n"
      " 0.125 0 0.001 1.125 2 3.001 \"\";\n";
  const auto tag_path = write_landmark_text(dir, "Case.tag", tag);
  expect_same(read_landmark_file(tag_path), t, "tag, first volume");
  Landmarks shifted = t;
  shifted.points.rowwise() += Eigen::RowVector3d(1, 2, 3);
  expect_same(read_landmark_file(tag_path, TagVolume::SECOND), shifted, "tag, second volume");
  // Slicer 5 markups, LPS (its default) and RAS.
  const auto markups = [](const std::string& system, double sx, double sy) {
    std::ostringstream s;
    s.precision(17);
    s << "{\"@schema\": \"https://raw.githubusercontent.com/slicer/slicer/master/Modules/"
         "Loadable/Markups/Resources/Schema/markups-schema-v1.0.3.json#\",\n"
         " \"markups\": [{\"type\": \"Fiducial\", \"coordinateSystem\": \""
      << system << "\", \"coordinateUnits\": \"mm\", \"controlPoints\": [\n";
    const Landmarks l = truth();
    for (int i = 0; i < 3; ++i)
      s << (i ? ",\n" : "") << "  {\"id\": \"" << i + 1 << "\", \"label\": \"" << l.ids[i]
        << "\", \"position\": [" << sx * l.points(i, 0) << ", " << sy * l.points(i, 1) << ", "
        << l.points(i, 2) << "], \"positionStatus\": \"defined\"}";
    // A point placed but then cleared in Slicer: skipped.
    s << ",\n  {\"id\": \"4\", \"label\": \"unplaced\", \"position\": [0.0, 0.0, 0.0], "
         "\"positionStatus\": \"undefined\"}]}]}\n";
    return s.str();
  };
  expect_same(read_landmark_file(write_landmark_text(dir, "lps.mrk.json", markups("LPS", -1, -1))),
              t, "mrk.json LPS");
  expect_same(read_landmark_file(write_landmark_text(dir, "ras.mrk.json", markups("RAS", 1, 1))), t,
              "mrk.json RAS");
  // Slicer 4.11's .fcsv (LPS), and an older one that says 0 (RAS).
  expect_same(read_landmark_file(write_landmark_text(
                  dir, "lps.fcsv",
                  "# Markups fiducial file version = 4.11\n# CoordinateSystem = LPS\n"
                  "# columns = id,x,y,z,ow,ox,oy,oz,vis,sel,lock,label,desc,associatedNodeID\n"
                  "vtkMRMLMarkupsFiducialNode_0,-50.164402,31.719656,34.845306,0,0,0,1,1,1,0,"
                  "1,\"a note, with a comma\",\n"
                  "vtkMRMLMarkupsFiducialNode_1,44.5,-31.25,-29.970621,0,0,0,1,1,1,0,2,,\n"
                  "vtkMRMLMarkupsFiducialNode_2,-0.125,-0,0.001,0,0,0,1,1,1,0,3,,\n")),
              t, "fcsv LPS");
  expect_same(read_landmark_file(write_landmark_text(
                  dir, "ras.fcsv",
                  "# Markups fiducial file version = 4.6\n# CoordinateSystem = 0\n"
                  "# columns = id,x,y,z,ow,ox,oy,oz,vis,sel,lock,label,desc,associatedNodeID\n"
                  "a,50.164402,-31.719656,34.845306,0,0,0,1,1,1,0,1,,\n"
                  "b,-44.5,31.25,-29.970621,0,0,0,1,1,1,0,2,,\n"
                  "c,0.125,0,0.001,0,0,0,1,1,1,0,3,,\n")),
              t, "fcsv RAS");
}

TEST(LandmarkFiles, MarkupsWeWriteAreLpsAndReadBackExactly) {
  const tests::TempFolder dir;
  const Landmarks t = truth();
  write_markups_json(dir / "out.mrk.json", t, {"a", "b", "c"});
  expect_same(read_landmark_file(dir / "out.mrk.json"), t, "round trip");
  std::ifstream in(dir / "out.mrk.json");
  const nlohmann::json j = nlohmann::json::parse(in);
  const auto& m = j["markups"][0];
  EXPECT_EQ(m["coordinateSystem"], "LPS");
  EXPECT_EQ(m["controlPoints"][1]["description"], "b");
  EXPECT_EQ(m["controlPoints"][1]["position"][0].get<double>(), 44.5);  // R → L: sign flipped
  EXPECT_EQ(dir.count(), 1u);  // nothing else (no temporary) left behind
}

/// RESECT's own summary line: "CaseN-MRI-beforeUS.tag  n= 15 mean=  1.82 sd= 0.87 min= 0.56
/// max=  3.84 mm".
TEST(LandmarkFiles, ResectTagFilesAgreeWithTheirPublishedSummary) {
  const auto folder = std::filesystem::path(tests::shared_data_dir) / "resect" / "landmarks";
  const auto summary = folder / "landmark_displacement_summary.txt";
  if (!std::filesystem::exists(summary))
    GTEST_SKIP() << "no real data: " << summary.string() << " is absent";
  std::ifstream in(summary);
  const std::regex line_re(
      R"((\S+\.tag)\s+n=\s*(\d+)\s+mean=\s*([\d.]+)\s+sd=\s*([\d.]+)\s+min=\s*([\d.]+)\s+max=\s*([\d.]+))");
  int files = 0;
  for (std::string line; std::getline(in, line);) {
    std::smatch m;
    if (!std::regex_search(line, m, line_re)) continue;
    ++files;
    const auto path = folder / m[1].str();
    const Landmarks mri = read_landmark_file(path, TagVolume::FIRST);
    const Landmarks us = read_landmark_file(path, TagVolume::SECOND);
    ASSERT_EQ(mri.ids.size(), std::stoul(m[2].str())) << path;
    ASSERT_EQ(us.ids, mri.ids) << path;
    const Eigen::VectorXd d = (mri.points - us.points).rowwise().norm();
    const double mean = d.mean();
    const double sd = std::sqrt((d.array() - mean).square().sum() / static_cast<double>(d.size()));
    const double sd1 =
        std::sqrt((d.array() - mean).square().sum() / static_cast<double>(d.size() - 1));
    // The summary prints two decimals: agreement to half a unit of the last digit (+ rounding).
    const double tol = 0.0051;
    EXPECT_NEAR(mean, std::stod(m[3].str()), tol) << path;
    EXPECT_TRUE(std::abs(sd - std::stod(m[4].str())) <= tol ||
                std::abs(sd1 - std::stod(m[4].str())) <= tol)
        << path << ": sd " << sd << " / " << sd1 << " against " << m[4].str();
    EXPECT_NEAR(d.minCoeff(), std::stod(m[5].str()), tol) << path;
    EXPECT_NEAR(d.maxCoeff(), std::stod(m[6].str()), tol) << path;
  }
  EXPECT_EQ(files, 22) << "RESECT has 22 landmark files";
}

TEST(LandmarkFiles, BadFilesGiveOneLineNamingTheFile) {
  const tests::TempFolder dir;
  expect_error([&] { read_landmark_file(dir / "absent.tag"); }, {"absent.tag", "no such file"});
  expect_error([&] { read_landmark_file(write_landmark_text(dir, "l.txt", "1 2 3\n")); },
               {"l.txt", "unknown landmark format"});
  expect_error([&] { read_landmark_file(write_landmark_text(dir, "a.tag", "Points =\n1 2 3;\n")); },
               {"a.tag", "not an MNI tag file"});
  const std::string head = "MNI Tag Point File\nVolumes = 1;\nPoints =\n";
  expect_error(
      [&] { read_landmark_file(write_landmark_text(dir, "b.tag", head + " 1 2 3\n 4 5 6\n")); },
      {"b.tag", "does not end with ';'"});
  expect_error(
      [&] { read_landmark_file(write_landmark_text(dir, "c.tag", head + " 1 2 3\n 4 5;\n")); },
      {"c.tag:5", "expected 3 coordinates", "got 2"});
  expect_error([&] { read_landmark_file(write_landmark_text(dir, "d.tag", head + " 1 2 nan;\n")); },
               {"d.tag:4", "finite number", "nan"});
  expect_error(
      [&] {
        read_landmark_file(
            write_landmark_text(dir, "e.tag", head + " 1 2 3 \"x\"\n 4 5 6 \"x\";\n"));
      },
      {"e.tag:5", "id x is repeated", "e.tag:4"});
  expect_error([&] { read_landmark_file(write_landmark_text(dir, "f.tag", head + ";\n")); },
               {"f.tag", "no landmarks"});
  expect_error(
      [&] { read_landmark_file(write_landmark_text(dir, "a.mrk.json", "{\"markups\": [")); },
      {"a.mrk.json", "not valid JSON"});
  // Found by fuzzing (tests/fuzz/crashes/landmarks): a number beyond double's range escaped as
  // the JSON library's own exception.
  expect_error(
      [&] { read_landmark_file(write_landmark_text(dir, "n.mrk.json", "{\"x\": 1e999}")); },
      {"n.mrk.json", "not valid JSON", "out of range"});
  expect_error(
      [&] { read_landmark_file(write_landmark_text(dir, "b.mrk.json", "{\"points\": []}")); },
      {"b.mrk.json", "not a Slicer markups file"});
  expect_error(
      [&] {
        read_landmark_file(write_landmark_text(
            dir, "c.mrk.json",
            R"({"markups": [{"coordinateSystem": "IJK", "controlPoints": []}]})"));
      },
      {"c.mrk.json", "markups[0]", "coordinateSystem must be LPS or RAS", "IJK"});
  expect_error(
      [&] {
        read_landmark_file(write_landmark_text(
            dir, "d.mrk.json",
            R"({"markups": [{"controlPoints": [{"label": "1", "position": [1, "2", 3]}]}]})"));
      },
      {"d.mrk.json", "controlPoints[0]", "three numbers"});
  expect_error(
      [&] {
        read_landmark_file(
            write_landmark_text(dir, "a.fcsv", "# CoordinateSystem = LPS\nF,1,2,x,0\n"));
      },
      {"a.fcsv:2", "finite number for z", "'x'"});
  expect_error(
      [&] {
        read_landmark_file(write_landmark_text(dir, "b.fcsv", "# CoordinateSystem = 2\nF,1,2,3\n"));
      },
      {"b.fcsv:1", "CoordinateSystem", "'2'"});
  expect_error([&] { read_landmark_file(write_landmark_text(dir, "c.fcsv", "# only comments\n")); },
               {"c.fcsv", "no landmarks"});
  expect_error([&] { write_markups_json(dir / "nowhere" / "x.mrk.json", truth()); },
               {"x.mrk.json"});
}

}  // namespace
}  // namespace brainshift::imaging
