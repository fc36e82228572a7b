#include "expect_error.hpp"
#include "tolerance.hpp"

#include "data_synth/geometry/phantom_mesh.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>

namespace brainshift::data_synth {
namespace {

double label_volume(const PhantomMesh& m, std::uint8_t label) {
  double v = 0;
  for (index_t t = 0; t < m.mesh.num_tets(); ++t)
    if (m.tet_labels[std::size_t(t)] == label) v += m.mesh.signed_volume(t);
  return v;
}

TEST(PhantomMesh, IsValidConformingAndFillsTheBrain) {
  const PhantomGeometry g;
  PhantomMeshOptions o;
  o.cell_size = 4.0;
  const PhantomMesh m = make_phantom_mesh(g, o);
  EXPECT_TRUE(core::find_mesh_issues(m.mesh).empty());
  // Conforming: every triangle belongs to one (boundary) or two (interior) tetrahedra, and every
  // boundary triangle's nodes are base or surface nodes.
  std::map<std::array<index_t, 3>, int> faces;
  for (index_t t = 0; t < m.mesh.num_tets(); ++t)
    for (int skip = 0; skip < 4; ++skip) {
      std::array<index_t, 3> f{};
      for (int a = 0, k = 0; a < 4; ++a)
        if (a != skip) f[std::size_t(k++)] = m.mesh.tets()(t, a);
      std::sort(f.begin(), f.end());
      ++faces[f];
    }
  std::vector<char> on_boundary(std::size_t(m.mesh.num_nodes()), 0);
  for (const index_t i : m.base_nodes) on_boundary[std::size_t(i)] = 1;
  for (const index_t i : m.surface_nodes) on_boundary[std::size_t(i)] = 1;
  for (const auto& [f, count] : faces) {
    ASSERT_LE(count, 2);
    if (count != 1) continue;
    for (const index_t i : f) ASSERT_TRUE(on_boundary[std::size_t(i)]) << "node " << i;
  }
  for (const index_t i : m.base_nodes) EXPECT_NEAR(m.mesh.nodes()(i, 2), g.base_level(), 1e-9);
  // Snapping: measured ≈ 70 % of the surface nodes end on the ellipsoid (the rest sit at
  // re-entrant stair corners, where a snap would crush a tetrahedron); none is farther from it
  // than the half cube diagonal √3/2·h, the stair-step bound.
  EXPECT_GT(m.snapped_nodes, index_t(0.6 * double(m.surface_nodes.size())));
  for (const index_t i : m.surface_nodes) {
    const Vector3d x = m.mesh.nodes().row(i).transpose();
    ASSERT_LE((g.brain_ellipsoid().closest_point(x) - x).norm(),
              0.5 * std::sqrt(3.0) * o.cell_size);
  }
  EXPECT_GT(core::quality_report(m.mesh).min_dihedral_deg, 5.0);  // measured 11°

  const PhantomVolumes a = analytic_volumes(g);
  double total = 0;
  for (index_t t = 0; t < m.mesh.num_tets(); ++t) total += m.mesh.signed_volume(t);
  // Snapped surface: the remaining error is the chordal error of 4 mm facets (≈ 0.5 %) and
  // the unsnapped rim near the base; 2 % bounds it.
  EXPECT_TRUE(tests::near(total, a.brain_total, 0, 2e-2));
  // Inclusions are resolved by tetrahedron centroids at h = 4 mm: ±15 % for a 12 mm sphere,
  // ±35 % for the thin (5 mm semi-axis) ventricles.
  EXPECT_TRUE(tests::near(label_volume(m, imaging::TUMOUR), a.tumour, 0, 0.15));
  EXPECT_TRUE(tests::near(label_volume(m, imaging::VENTRICLES), a.ventricles, 0, 0.35));
  for (index_t t = 0; t < m.mesh.num_tets(); ++t) {
    const double E = m.mesh.youngs_modulus()(t);
    const auto l = m.tet_labels[std::size_t(t)];
    ASSERT_EQ(E, l == imaging::TUMOUR       ? o.tumour_youngs_modulus
                 : l == imaging::VENTRICLES ? o.ventricle_youngs_modulus
                                            : o.brain_youngs_modulus);
  }
  RecordProperty("nodes", m.mesh.num_nodes());
  RecordProperty("tets", m.mesh.num_tets());
}

TEST(PhantomMesh, RejectsBadOptions) {
  PhantomMeshOptions o;
  o.cell_size = 0;
  tests::expect_error([&] { (void)make_phantom_mesh({}, o); }, {"cell_size"});
  o = {};
  o.poisson_ratio = 0.5;
  tests::expect_error([&] { (void)make_phantom_mesh({}, o); }, {"poisson_ratio"});
}

}  // namespace
}  // namespace brainshift::data_synth
