#include "tolerance.hpp"

#include "core/error.hpp"
#include "core/mesh/tet_mesh.hpp"
#include "data_synth/geometry/structured_mesh.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace brainshift::core {
namespace {

TetMesh unit_tet() {
  MatrixX3d X(4, 3);
  X << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1;
  MatrixX4i T(1, 4);
  T << 0, 1, 2, 3;
  return TetMesh(X, T);
}

TEST(TetMesh, DefaultsMaterialsToBrain) {
  const TetMesh m = unit_tet();
  EXPECT_EQ(m.youngs_modulus()(0), 1.5);
  EXPECT_EQ(m.poisson_ratio()(0), 0.45);
  // Volume of the unit corner tetrahedron is exactly 1/6 up to one rounding.
  EXPECT_TRUE(tests::near(m.signed_volume(0), 1.0 / 6.0, 0, 4 * tests::eps));
  EXPECT_NO_THROW(validate(m));
}

TEST(TetMesh, BoxMeshIsValidAndHasTheExactVolume) {
  const TetMesh m = data_synth::make_box_mesh({10, 20, 30}, {3, 4, 5});
  EXPECT_EQ(m.num_nodes(), 4 * 5 * 6);
  EXPECT_EQ(m.num_tets(), 6 * 3 * 4 * 5);
  EXPECT_TRUE(find_mesh_issues(m).empty());
  double volume = 0;
  for (index_t t = 0; t < m.num_tets(); ++t) volume += m.signed_volume(t);
  // Kuhn tetrahedra tile the box exactly; only summation rounding remains.
  EXPECT_TRUE(tests::near(volume, 6000.0, 0, 1e-12));
}

TEST(TetMesh, CurvedMeshesAreValid) {
  EXPECT_TRUE(find_mesh_issues(data_synth::make_cylinder_mesh(10, 40, 8, 10)).empty());
  EXPECT_TRUE(find_mesh_issues(data_synth::make_ellipsoid_mesh({60, 70, 50}, 8)).empty());
}

TEST(TetMesh, InvertedElementIsNamed) {
  MatrixX3d X(4, 3);
  X << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1;
  MatrixX4i T(1, 4);
  T << 0, 2, 1, 3;  // swapped: negative volume
  const auto issues = find_mesh_issues(TetMesh(X, T));
  ASSERT_EQ(issues.size(), 1u);
  EXPECT_EQ(issues[0].kind, MeshIssue::Kind::NON_POSITIVE_VOLUME);
  EXPECT_EQ(issues[0].index, 0);
  try {
    validate(TetMesh(X, T), "m.vtu");
    FAIL() << "validate accepted an inverted tetrahedron";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("m.vtu"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("tetrahedron 0"), std::string::npos) << e.what();
  }
}

TEST(TetMesh, ZeroVolumeNaNOutOfRangeAndUnusedAreNamed) {
  MatrixX3d X(6, 3);
  X << 0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0,             // 4 coplanar nodes
      std::numeric_limits<double>::quiet_NaN(), 0, 0,  // NaN node 4
      5, 5, 5;                                         // unused node 5
  MatrixX4i T(3, 4);
  T << 0, 1, 2, 3,  // flat
      0, 1, 2, 4,   // uses the NaN node
      0, 1, 2, 9;   // out of range
  const auto issues = find_mesh_issues(TetMesh(X, T));
  auto has = [&](MeshIssue::Kind k, index_t i) {
    for (const auto& is : issues)
      if (is.kind == k && is.index == i) return true;
    return false;
  };
  EXPECT_TRUE(has(MeshIssue::Kind::NAN_COORDINATE, 4));
  EXPECT_TRUE(has(MeshIssue::Kind::INDEX_OUT_OF_RANGE, 2));
  EXPECT_TRUE(has(MeshIssue::Kind::NON_POSITIVE_VOLUME, 0));
  EXPECT_TRUE(has(MeshIssue::Kind::UNUSED_NODE, 5));
}

TEST(TetMesh, BadMaterialIsNamed) {
  MatrixX3d X(4, 3);
  X << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1;
  MatrixX4i T(1, 4);
  T << 0, 1, 2, 3;
  const auto issues = find_mesh_issues(
      TetMesh(X, T, Eigen::VectorXd::Constant(1, 1.5), Eigen::VectorXd::Constant(1, 0.5)));
  ASSERT_EQ(issues.size(), 1u);
  EXPECT_EQ(issues[0].kind, MeshIssue::Kind::BAD_MATERIAL);
}

TEST(TetMesh, QualityReportFindsTheRegularTetAndASliver) {
  // Regular tetrahedron: all dihedral angles acos(1/3) = 70.5288°.
  Eigen::Matrix<double, 4, 3> R;
  R << 1, 1, 1, 1, -1, -1, -1, 1, -1, -1, -1, 1;
  for (double a : dihedral_angles_deg(R)) EXPECT_TRUE(tests::near(a, 70.528779365509, 1e-9, 0));
  // A sliver: four nearly coplanar points forming a square.
  MatrixX3d X(8, 3);
  X << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1,  //
      10, 0, 0, 11, 0, 0, 11, 1, 0.01, 10, 1, 0;
  MatrixX4i T(2, 4);
  T << 0, 1, 2, 3, 4, 5, 6, 7;
  TetMesh m(X, T);
  if (m.signed_volume(1) < 0) T.row(1) << 4, 6, 5, 7;
  const QualityReport q = quality_report(TetMesh(X, T), 5.0);
  EXPECT_EQ(q.sliver_count, 1);
  EXPECT_EQ(q.worst_tet, 1);
  EXPECT_LT(q.min_dihedral_deg, 5.0);
}

}  // namespace
}  // namespace brainshift::core
