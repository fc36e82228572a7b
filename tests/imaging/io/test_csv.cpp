#include "expect_error.hpp"
#include "temp_folder.hpp"

#include "core/error.hpp"
#include "imaging/io/csv.hpp"

#include <gtest/gtest.h>

#include <fstream>
#include <string>

namespace brainshift::imaging {
namespace {

std::filesystem::path write_text(const tests::TempFolder& dir, const std::string& name,
                                 const std::string& text) {
  const auto path = dir / name;
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

using tests::expect_error;

TEST(Csv, NodeListToleratesBlankLinesSpacesAndCrLf) {
  const tests::TempFolder dir;
  const auto path = write_text(dir, "fixed.csv", "node\r\n3\r\n\r\n  17 \r\n0\n");
  EXPECT_EQ(read_node_list(path), (std::vector<index_t>{3, 17, 0}));
  EXPECT_EQ(read_node_list(path, /*num_nodes=*/18).size(), 3u);
}

TEST(Csv, DisplacementsRoundTripExactly) {
  const tests::TempFolder dir;
  const std::vector<core::PrescribedDisplacement> d = {{4, {0.1, -2.0 / 3.0, 1e-17}},
                                                       {0, {10, 0, -1e300}}};
  write_node_displacements(dir / "d.csv", d);
  const auto back = read_node_displacements(dir / "d.csv");
  ASSERT_EQ(back.size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    EXPECT_EQ(back[i].node, d[i].node);
    EXPECT_EQ(back[i].displacement, d[i].displacement);  // max_digits10: exact
  }
  write_node_list(dir / "n.csv", {5, 1, 2});
  EXPECT_EQ(read_node_list(dir / "n.csv"), (std::vector<index_t>{5, 1, 2}));
  EXPECT_EQ(dir.count(), 2u);
}

TEST(Csv, LandmarksRoundTripExactlyAndRejectRepeatedIds) {
  const tests::TempFolder dir;
  Landmarks l;
  l.ids = {"bifurcation_1", "7", "deep-tumour"};
  l.points.resize(3, 3);
  l.points << 1.0 / 3.0, -2.5, 1e-7, 100.25, 0, -0.1, 3, 4, 5;
  write_landmarks(dir / "l.csv", l);
  const Landmarks back = read_landmarks(dir / "l.csv");
  EXPECT_EQ(back.ids, l.ids);
  EXPECT_EQ(back.points, l.points);  // max_digits10: exact
  const auto bad = write_text(dir, "bad.csv", "id,x,y,z\na,1,2,3\na,4,5,6\n");
  tests::expect_error([&] { read_landmarks(bad); }, {"bad.csv:3", "id a is repeated"});
  const auto nan = write_text(dir, "nan.csv", "id,x,y,z\na,1,nan,3\n");
  tests::expect_error([&] { read_landmarks(nan); }, {"nan.csv:2"});
}

TEST(Csv, HeaderWithSpacesIsAccepted) {
  const tests::TempFolder dir;
  const auto path = write_text(dir, "d.csv", "node, dx, dy, dz\n1, +1.5, 0, -2e-1\n");
  const auto d = read_node_displacements(path);
  ASSERT_EQ(d.size(), 1u);
  EXPECT_EQ(d[0].displacement, Vector3d(1.5, 0, -0.2));
}

struct BadCsv {
  const char* name;
  bool displacement;  // which reader
  const char* text;
  const char* needle;  // expected in the message besides "file:line"
  int line;
};

class CsvErrors : public ::testing::TestWithParam<BadCsv> {};

TEST_P(CsvErrors, NameTheFileAndLine) {
  const BadCsv& c = GetParam();
  SCOPED_TRACE(c.name);
  const tests::TempFolder dir;
  const auto path = write_text(dir, "in.csv", c.text);
  const std::string where = path.string() + ":" + std::to_string(c.line);
  if (c.displacement) {
    expect_error([&] { (void)read_node_displacements(path, 10); }, {where, c.needle});
  } else {
    expect_error([&] { (void)read_node_list(path, 10); }, {where, c.needle});
  }
}

INSTANTIATE_TEST_SUITE_P(
    AllCases, CsvErrors,
    ::testing::Values(
        BadCsv{"wrong header", false, "id\n1\n", "expected the header 'node'", 1},
        BadCsv{"not a number", false, "node\n1\nabc\n", "'abc'", 3},
        BadCsv{"negative", false, "node\n-1\n", "'-1'", 2},
        BadCsv{"fraction", false, "node\n1.5\n", "'1.5'", 2},
        BadCsv{"out of range", false, "node\n\n10\n", "node 10 is out of range", 3},
        BadCsv{"two fields", false, "node\n1,2\n", "one field", 2},
        BadCsv{"wrong displacement header", true, "node,x,y,z\n", "node,dx,dy,dz", 1},
        BadCsv{"three fields", true, "node,dx,dy,dz\n1,2,3\n", "4 fields", 2},
        BadCsv{"nan", true, "node,dx,dy,dz\n1,0,nan,0\n", "dy", 2},
        BadCsv{"text value", true, "node,dx,dy,dz\n1,0,0,up\n", "'up'", 2},
        BadCsv{"id out of range", true, "node,dx,dy,dz\n0,0,0,0\n12,0,0,0\n", "out of range", 3},
        BadCsv{"repeated node", true, "node,dx,dy,dz\n2,0,0,0\n2,1,0,0\n", "repeated", 3}),
    [](const ::testing::TestParamInfo<BadCsv>& param_info) {
      std::string s = param_info.param.name;
      for (char& ch : s)
        if (ch == ' ') ch = '_';
      return s;
    });

TEST(Csv, MissingAndEmptyFilesAreNamed) {
  const tests::TempFolder dir;
  expect_error([&] { (void)read_node_list(dir / "none.csv"); }, {"none.csv", "no such file"});
  const auto empty = write_text(dir, "empty.csv", "");
  expect_error([&] { (void)read_node_displacements(empty); }, {"empty.csv", "empty"});
}

TEST(Csv, UnwritableFolderIsNamed) {
  const tests::TempFolder dir;
  const auto path = dir / "missing" / "n.csv";
  expect_error([&] { write_node_list(path, {1}); }, {path.string()});
}

}  // namespace
}  // namespace brainshift::imaging
