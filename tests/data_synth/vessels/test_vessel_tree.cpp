#include "core/error.hpp"
#include "data_synth/vessels/tree_graph.hpp"
#include "data_synth/vessels/vessel_tree.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace brainshift::data_synth {
namespace {

VesselTreeOptions seeded(std::uint32_t seed) {
  VesselTreeOptions o;
  o.seed = seed;
  return o;
}

class VesselTreeSeeds : public ::testing::TestWithParam<std::uint32_t> {};

TEST_P(VesselTreeSeeds, RadiiGenerationsAndPointsStayWithinTheirBounds) {
  SCOPED_TRACE("seed " + std::to_string(GetParam()));
  const PhantomGeometry g;
  const VesselTreeOptions o = seeded(GetParam());
  const VesselTree tree = make_vessel_tree(g, o);
  ASSERT_GT(tree.size(), 50);
  EXPECT_GE(tree.max_generation(), 3);
  EXPECT_LE(tree.max_generation(), 6);
  EXPECT_GE(tree.bifurcations().size(), 4U);
  for (index_t i = 0; i < tree.size(); ++i) {
    const Vector3d& p = tree.points[std::size_t(i)];
    EXPECT_GE(tree.radius[std::size_t(i)], 0.5) << "point " << i;
    EXPECT_LE(tree.radius[std::size_t(i)], 3.0) << "point " << i;
    EXPECT_TRUE(g.inside_brain(p)) << "point " << i << " at " << p.transpose();
    EXPECT_EQ(g.label_at(p), imaging::BRAIN) << "point " << i;
  }
  // Murray's law at every bifurcation that ends a branch (both children one generation
  // further): r³ = Σ children r³ (child radii read at the first point of each child branch).
  // Points where a penetrating branch leaves a running cortical branch are not such splits.
  std::vector<std::vector<index_t>> children(tree.points.size());
  for (const auto& e : tree.edges) children[std::size_t(e[0])].push_back(e[1]);
  for (std::size_t i = 0; i < children.size(); ++i) {
    if (children[i].size() != 2) continue;
    const int g1 = tree.generation[i] + 1;
    if (tree.generation[std::size_t(children[i][0])] != g1 ||
        tree.generation[std::size_t(children[i][1])] != g1)
      continue;
    double sum = 0.0;
    for (const index_t c : children[i]) sum += std::pow(tree.radius[std::size_t(c)], 3.0);
    EXPECT_NEAR(sum, std::pow(tree.radius[i], 3.0), 1e-9 * sum) << "bifurcation " << i;
  }
}

INSTANTIATE_TEST_SUITE_P(Seeds, VesselTreeSeeds, ::testing::Values(1U, 2U, 7U, 12345U));

TEST(VesselTree, IsDeterministicForASeedAndDiffersBetweenSeeds) {
  const PhantomGeometry g;
  const VesselTree a = make_vessel_tree(g, seeded(42));
  const VesselTree b = make_vessel_tree(g, seeded(42));
  const VesselTree c = make_vessel_tree(g, seeded(43));
  ASSERT_EQ(a.size(), b.size());
  for (index_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a.points[std::size_t(i)], b.points[std::size_t(i)]);
    EXPECT_EQ(a.radius[std::size_t(i)], b.radius[std::size_t(i)]);
  }
  EXPECT_EQ(a.edges, b.edges);
  const bool same = a.size() == c.size() && a.points == c.points;
  EXPECT_FALSE(same);
}

TEST(VesselTree, OneSideTreesStayOnTheirSideOfTheCraniotomy) {
  const PhantomGeometry g;
  VesselTreeOptions o = seeded(5);
  o.one_side = true;
  o.deep_branches = 0;
  const VesselTree tree = make_vessel_tree(g, o);
  ASSERT_GT(tree.size(), 0);
  // Roots lie on the +R side of the craniotomy centre: the roots' mean is there.
  Vector3d mean = Vector3d::Zero();
  int roots = 0;
  for (index_t i = 0; i < tree.size(); ++i)
    if (tree.degrees()[std::size_t(i)] == 1 && tree.generation[std::size_t(i)] == 1) {
      mean += tree.points[std::size_t(i)];
      ++roots;
    }
  ASSERT_GT(roots, 0);
  EXPECT_GT(mean.x() / roots, g.craniotomy_centre_on_brain().x());
}

TEST(VesselTree, RoundTripsThroughAVesselGraph) {
  const VesselTree tree = make_vessel_tree(PhantomGeometry{}, seeded(3));
  const imaging::VesselGraph graph = to_vessel_graph(tree);
  EXPECT_EQ(graph.junction_count(), int(tree.bifurcations().size()));
  const VesselTree back = from_vessel_graph(graph);
  EXPECT_EQ(back.size(), tree.size());
  EXPECT_EQ(back.edges.size(), tree.edges.size());
  EXPECT_EQ(back.bifurcations().size(), tree.bifurcations().size());
}

TEST(VesselTree, AUserTreeIsScaledAndPlacedInsideTheBrain) {
  // A large straight "Y" far outside the phantom, with a radius of 0 on one branch (missing).
  VesselTree user;
  user.points = {{500, 500, 500}, {500, 600, 500}, {450, 700, 500}, {550, 700, 500}};
  user.radius = {4.0, 3.0, 0.0, 2.0};
  user.generation = {1, 1, 2, 2};
  user.edges = {{0, 1}, {1, 2}, {1, 3}};
  const PhantomGeometry g;
  const VesselTree placed = place_user_tree(user, g);
  for (index_t i = 0; i < placed.size(); ++i) {
    EXPECT_TRUE(g.inside_brain(placed.points[std::size_t(i)])) << "point " << i;
    EXPECT_GE(placed.radius[std::size_t(i)], 0.5);
    EXPECT_LE(placed.radius[std::size_t(i)], 3.0);
  }
}

TEST(VesselTree, RejectsInvalidOptions) {
  VesselTreeOptions o;
  o.min_radius = 0.0;
  EXPECT_THROW((void)make_vessel_tree(PhantomGeometry{}, o), Error);
}

}  // namespace
}  // namespace brainshift::data_synth
