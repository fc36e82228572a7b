// Each constraint builder's rows on a unit cube (issue 19 item 1): the row's direction and the
// sign of its violation for a point inside and outside the cube, in each mode, and the rows'
// Jacobian against finite differences of their values. A flipped normal (the unilateral dura,
// the footprint's fallback) turns a contact that pushes the brain back into one that pulls it
// through the skull or probe; these tests fail on exactly that.
#include "constraints/registration/pairing/pairing.hpp"
#include "constraints/registration/rows/constraint_builders.hpp"
#include "core/mesh/boundary.hpp"
#include "data_synth/geometry/structured_mesh.hpp"

#include <gtest/gtest.h>

#include <random>

namespace brainshift::constraints {
namespace {

struct Cube {
  core::TetMesh mesh = data_synth::make_box_mesh({1, 1, 1}, {2, 2, 2});
  core::SurfaceMesh surface;
  core::BarycentricMapping map;
  std::unique_ptr<FeatureIndex> rest;
  MatrixX3d normals;
  index_t top = -1;       ///< surface vertex at the centre of the top face (0.5, 0.5, 1)
  index_t top_node = -1;  ///< its mesh node
  Cube() {
    const core::BoundarySurface b = core::boundary_surface(mesh);
    surface = {b.vertices, b.faces};
    map = core::BarycentricMapping(mesh, surface.vertices);
    rest = std::make_unique<FeatureIndex>(
        FeatureIndex::triangles(surface.vertices, surface.triangles));
    normals = vertex_normals(surface);
    for (index_t v = 0; v < surface.vertices.rows(); ++v)
      if ((surface.vertices.row(v) - Eigen::RowVector3d(0.5, 0.5, 1.0)).norm() < 1e-12) top = v;
    top_node = b.node_of_vertex[static_cast<std::size_t>(top)];
  }
  [[nodiscard]] MappedVertices mapped() const { return {&mesh, &map}; }
  /// Rest positions with the top-centre node moved by dz (mm).
  [[nodiscard]] MatrixX3d moved(double dz) const {
    MatrixX3d x = mesh.nodes();
    x(top_node, 2) += dz;
    return x;
  }
};

/// The row of `rows` built for feature `f`.
const ConstraintRow& row_of(const ConstraintRows& rows, std::int64_t f) {
  for (const ConstraintRow& r : rows.rows())
    if (r.feature == f) return r;
  throw std::runtime_error("no row for feature " + std::to_string(f));
}

/// Jacobian against finite differences: the rows are linear in x for fixed directions, so
/// H dx = g(x + dx) − g(x) to rounding, and g at the build positions is the stored violation.
void expect_jacobian_matches_differences(const ConstraintRows& rows, const MatrixX3d& x) {
  std::mt19937 rng(5);
  std::normal_distribution<double> n(0.0, 0.01);
  MatrixX3d dx(x.rows(), 3);
  for (Eigen::Index i = 0; i < dx.size(); ++i) dx.data()[i] = n(rng);
  const MatrixX3d x1 = x + dx;
  const Eigen::VectorXd fd = rows.values(x1) - rows.values(x);
  const Eigen::VectorXd h =
      rows.jacobian(x.rows()) * Eigen::Map<const Eigen::VectorXd>(dx.data(), dx.size());
  EXPECT_LT((fd - h).cwiseAbs().maxCoeff(), 1e-12);  // linear rows: rounding only
  EXPECT_LT((rows.values(x) - rows.violations()).cwiseAbs().maxCoeff(), 1e-12);
}

TEST(Builders, SlidingDuraRowPointsOutwardAndMeasuresTheDistanceOutside) {
  const Cube c;
  DuraOptions o;
  o.mode = DuraOptions::Mode::SLIDING;
  o.craniotomy_centre = Vector3d(10, 10, 10);  // far: every vertex gets a row
  for (double dz : {0.1, -0.1}) {              // outside, then inside the cube
    ConstraintRows rows;
    const MatrixX3d x = c.moved(dz);
    add_dura_rows(rows, o, c.surface, *c.rest, c.normals, c.mapped(), x);
    const ConstraintRow& r = row_of(rows, c.top);
    EXPECT_EQ(r.law, ConstraintLaw::BILATERAL);
    EXPECT_LT((r.direction - Vector3d::UnitZ()).norm(), 1e-12) << r.direction.transpose();
    EXPECT_NEAR(r.violation, dz, 1e-12);  // signed distance, positive outside
    expect_jacobian_matches_differences(rows, x);
  }
}

TEST(Builders, UnilateralDuraRowPointsInwardAndIsViolatedOnlyOutside) {
  const Cube c;
  DuraOptions o;
  o.mode = DuraOptions::Mode::UNILATERAL;
  o.craniotomy_centre = Vector3d(10, 10, 10);
  for (double dz : {0.1, -0.1}) {
    ConstraintRows rows;
    const MatrixX3d x = c.moved(dz);
    add_dura_rows(rows, o, c.surface, *c.rest, c.normals, c.mapped(), x);
    const ConstraintRow& r = row_of(rows, c.top);
    EXPECT_EQ(r.law, ConstraintLaw::UNILATERAL);
    // Allowed side: inside. A positive λ pushes the vertex along −z, back under the dura.
    EXPECT_LT((r.direction + Vector3d::UnitZ()).norm(), 1e-12) << r.direction.transpose();
    EXPECT_NEAR(r.violation, -dz, 1e-12);  // g < 0 (violated) outside, g > 0 (free) inside
    expect_jacobian_matches_differences(rows, x);
  }
}

TEST(Builders, NoDuraRowsInsideTheCraniotomy) {
  const Cube c;
  DuraOptions o;
  o.mode = DuraOptions::Mode::SLIDING;
  o.craniotomy_centre = Vector3d(0.5, 0.5, 1.0);
  o.craniotomy_radius_mm = 0.3;
  ConstraintRows rows;
  add_dura_rows(rows, o, c.surface, *c.rest, c.normals, c.mapped(), c.mesh.nodes());
  EXPECT_THROW((void)row_of(rows, c.top), std::runtime_error);
  EXPECT_EQ(rows.size(), c.surface.vertices.rows() - 1);  // only the top centre is within 0.3 mm
}

/// One footprint point above (outside, z = 1.1) or pressed into (inside, z = 0.9) the top face.
void check_footprint(bool given_normals) {
  const Cube c;
  for (double z : {1.1, 0.9}) {
    MatrixX3d pts(1, 3);
    pts << 0.3, 0.4, z;
    const MatrixX3d nrm = given_normals ? MatrixX3d(Eigen::RowVector3d(0, 0, -1)) : MatrixX3d(0, 3);
    const FeatureIndex index = FeatureIndex::triangles(c.surface.vertices, c.surface.triangles);
    auto p = index.nearest(pts.row(0).transpose(), 1.0);
    ASSERT_TRUE(p.has_value());
    p->point = 0;
    ConstraintRows rows;
    add_footprint_rows(rows, {*p}, c.surface, c.mapped(), c.mesh.nodes(), pts, nrm);
    ASSERT_EQ(rows.size(), 1);
    const ConstraintRow& r = rows[0];
    EXPECT_EQ(r.law, ConstraintLaw::UNILATERAL);
    // Into the tissue (−z) whether given or taken from the paired triangle (the fallback).
    EXPECT_LT((r.direction + Vector3d::UnitZ()).norm(), 1e-12) << r.direction.transpose();
    // The surface (z = 1) is on the tissue side of a probe at 1.1 (g = +0.1, free) and must be
    // pushed down by a probe at 0.9 (g = −0.1).
    EXPECT_NEAR(r.violation, z - 1.0, 1e-12);
    expect_jacobian_matches_differences(rows, c.mesh.nodes());
  }
}

TEST(Builders, FootprintRowWithGivenNormalsPointsIntoTheTissue) { check_footprint(true); }
TEST(Builders, FootprintRowWithTheTriangleFallbackNormalPointsIntoTheTissue) {
  check_footprint(false);
}

TEST(Builders, VesselRowsAreNormalToTheVesselAndMeasureTheDistanceToThePoint) {
  const Cube c;
  core::Skeleton s;
  s.points.resize(2, 3);
  s.points << 0.25, 0.5, 0.5, 0.75, 0.5, 0.5;  // along x, inside the cube
  s.segments = {{0, 1}};
  const core::BarycentricMapping map(c.mesh, s.points);
  const MappedVertices mv{&c.mesh, &map};
  for (double z : {0.7, 1.3}) {  // an intra-operative point inside, then outside the cube
    MatrixX3d pts(1, 3);
    pts << 0.5, 0.5, z;
    const FeatureIndex index = FeatureIndex::segments(s.points, s.segments);
    Pair p = index.closest_on(0, pts.row(0).transpose());
    p.point = 0;
    ConstraintRows rows;
    add_vessel_rows(rows, {p}, s, mv, c.mesh.nodes(), pts);
    ASSERT_EQ(rows.size(), 2);
    for (const ConstraintRow& r : rows.rows()) {
      EXPECT_EQ(r.law, ConstraintLaw::BILATERAL);
      EXPECT_NEAR(r.direction.dot(Vector3d::UnitX()), 0.0, 1e-12);  // free along the vessel
    }
    // The first normal points from the point towards the model's vessel (−z here), and the
    // violation is the distance; the second row is met.
    EXPECT_LT((rows[0].direction + Vector3d::UnitZ()).norm(), 1e-12)
        << rows[0].direction.transpose();
    EXPECT_NEAR(rows[0].violation, z - 0.5, 1e-12);
    EXPECT_NEAR(rows[1].violation, 0.0, 1e-12);
    expect_jacobian_matches_differences(rows, c.mesh.nodes());
  }
}

TEST(Builders, LandmarkRowsAreTheThreeAxesWithTheSignedOffset) {
  const Cube c;
  MatrixX3d model_pts(1, 3), targets(1, 3);
  model_pts << 0.4, 0.6, 0.5;
  targets << 0.4 + 0.2, 0.6 - 0.1, 1.5;  // the target outside the cube
  const core::BarycentricMapping map(c.mesh, model_pts);
  ConstraintRows rows;
  add_landmark_rows(rows, MappedVertices{&c.mesh, &map}, c.mesh.nodes(), targets);
  ASSERT_EQ(rows.size(), 3);
  for (int k = 0; k < 3; ++k) {
    EXPECT_LT((rows[k].direction - Vector3d::Unit(k)).norm(), 1e-12);
    EXPECT_NEAR(rows[k].violation, model_pts(0, k) - targets(0, k), 1e-12);  // g = p − target
  }
  expect_jacobian_matches_differences(rows, c.mesh.nodes());
}

}  // namespace
}  // namespace brainshift::constraints
