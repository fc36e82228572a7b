#include "expect_error.hpp"
#include "temp_folder.hpp"
#include "tests/config.hpp"

#include "imaging/io/skeleton_io.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

namespace brainshift::imaging {
namespace {

/// A Y: three branches meeting at node 0.
VesselGraph y_graph() {
  VesselGraph g;
  g.nodes = {{{0.5, 1.25, -3}, 2.5}, {{-20, 0, 0}, 1.0}, {{15, 12, 1}, 1.5}, {{15, -12, -1}, 1.25}};
  const auto branch = [&](index_t to, const Vector3d& middle, double r) {
    VesselGraph::Branch b;
    b.from = 0;
    b.to = to;
    b.points = {g.nodes[0].position, middle, g.nodes[std::size_t(to)].position};
    b.radius = {g.nodes[0].radius, r, g.nodes[std::size_t(to)].radius};
    return b;
  };
  g.branches = {branch(1, {-10, 0.5, -1.5}, 2.0), branch(2, {8, 6, -1}, 1.75),
                branch(3, {8, -6, -2}, 1.6)};
  return g;
}

TEST(SkeletonIo, RoundTripKeepsNodesBranchesAndRadiiExactly) {
  const tests::TempFolder dir;
  const VesselGraph written = y_graph();
  write_skeleton_vtp(dir / "y.vtp", written);
  EXPECT_EQ(dir.count(), 1u);
  const VesselGraph read = read_skeleton_vtp(dir / "y.vtp");
  ASSERT_EQ(read.branches.size(), written.branches.size());
  EXPECT_EQ(read.nodes.size(), written.nodes.size());
  EXPECT_EQ(read.junction_count(), 1) << "branches must share their junction point";
  for (std::size_t b = 0; b < written.branches.size(); ++b) {
    // Binary doubles: exact.
    EXPECT_EQ(read.branches[b].points, written.branches[b].points);
    EXPECT_EQ(read.branches[b].radius, written.branches[b].radius);
  }
}

TEST(SkeletonIo, ReadsVmtkCenterlinesWithTheirInscribedSphereRadius) {
  const std::filesystem::path file =
      std::filesystem::path(tests::shared_data_dir) / "vmtk" / "aorta-centerline.vtp";
  if (!std::filesystem::exists(file)) GTEST_SKIP() << "shared data absent: " << file;
  const VesselGraph g = read_skeleton_vtp(file);
  // README of the data: 409 points in 2 lines, radii 2.78–7.58 mm.
  ASSERT_EQ(g.branches.size(), 2u);
  std::size_t points = 0;
  double r_min = 1e300, r_max = 0.0;
  for (const auto& b : g.branches) {
    points += b.points.size();
    for (const double r : b.radius) {
      r_min = std::min(r_min, r);
      r_max = std::max(r_max, r);
    }
  }
  EXPECT_EQ(points, 409u);
  EXPECT_NEAR(r_min, 2.7758680852, 1e-9);
  EXPECT_NEAR(r_max, 7.5780218521, 1e-9);
}

TEST(SkeletonIo, BadFilesAreOneLineErrors) {
  const tests::TempFolder dir;
  tests::expect_error([&] { read_skeleton_vtp(dir / "absent.vtp"); },
                      {"absent.vtp", "no such file"});
  std::ofstream(dir / "junk.vtp") << "not xml";
  tests::expect_error([&] { read_skeleton_vtp(dir / "junk.vtp"); }, {"junk.vtp"});
  tests::expect_error([&] { write_skeleton_vtp(dir / "missing" / "s.vtp", y_graph()); },
                      {"s.vtp", "does not exist"});
}

}  // namespace
}  // namespace brainshift::imaging
