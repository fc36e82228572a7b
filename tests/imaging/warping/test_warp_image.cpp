#include "expect_error.hpp"
#include "tolerance.hpp"

#include "data_synth/geometry/structured_mesh.hpp"
#include "imaging/warping/warp_image.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <optional>

namespace brainshift::imaging {
namespace {

using tests::expect_error;

constexpr double FLOAT_EPS = std::numeric_limits<float>::epsilon();

/// 40 × 44 × 36 voxels, anisotropic spacing, optionally a rotated (and reflected) direction.
ImageGeometry test_grid(bool rotated) {
  ImageGeometry g;
  g.size = Eigen::Vector3i(40, 44, 36);
  g.spacing = Vector3d(1.0, 1.1, 1.3);
  g.origin = Vector3d(-18.0, -25.0, -20.0);
  if (rotated) {
    g.direction = Vector3d(-1, -1, 1).asDiagonal() *
                  Eigen::AngleAxisd(0.4, Vector3d(1, -2, 0.5).normalized()).toRotationMatrix();
    g.origin = Vector3d(12.0, 20.0, -20.0);
  }
  return g;
}

VolumeF make_image(const ImageGeometry& g, const std::function<double(const Vector3d&)>& f) {
  VolumeF v(g);
  for (int k = 0; k < g.size[2]; ++k)
    for (int j = 0; j < g.size[1]; ++j)
      for (int i = 0; i < g.size[0]; ++i)
        v.at(i, j, k) = float(f(g.index_to_world(Vector3d(i, j, k))));
  return v;
}

/// A box mesh around the world origin, well inside both test grids (≈ 24 × 24 × 20 mm).
core::TetMesh test_box() {
  return data_synth::make_box_mesh(Vector3d(24, 24, 20), Eigen::Vector3i(4, 4, 3),
                                   Vector3d(-12, -12, -10));
}

bool inside_box(const Vector3d& X, double margin) {
  return (X.array() >= Eigen::Array3d(-12, -12, -10) + margin).all() &&
         (X.array() <= Eigen::Array3d(12, 12, 10) - margin).all();
}

/// Pre-image strictly inside the image grid (trilinear interpolation without clamping).
bool inside_grid(const ImageGeometry& g, const Vector3d& X) {
  const Vector3d ijk = g.world_to_index(X);
  return (ijk.array() >= 0.0).all() && (ijk.array() <= (g.size.array() - 1).cast<double>()).all();
}

TEST(WarpImage, IdentityDisplacementReproducesTheImage) {
  for (bool rotated : {false, true}) {
    SCOPED_TRACE(rotated ? "rotated direction" : "identity direction");
    const ImageGeometry g = test_grid(rotated);
    const VolumeF in = make_image(g, [](const Vector3d& p) {
      return 100.0 + 50.0 * std::sin(0.3 * p.x()) * std::cos(0.2 * p.y() + 0.1 * p.z());
    });
    const core::TetMesh mesh = test_box();
    const VolumeF out = warp_image(in, mesh, MatrixX3d::Zero(mesh.num_nodes(), 3));
    ASSERT_EQ(out.data.size(), in.data.size());
    double worst = 0.0;
    for (std::size_t v = 0; v < in.data.size(); ++v)
      worst = std::max(worst, double(std::abs(out.data[v] - in.data[v])));
    // At voxel centres the interpolation weights are 0/1 up to rounding of the index maps
    // (≈ 1e-13), so the value is exact within a float ulp of the largest value (150).
    EXPECT_LE(worst, 150.0 * FLOAT_EPS);
  }
}

TEST(WarpImage, TranslationMovesASmoothBlob) {
  const ImageGeometry g = test_grid(/*rotated=*/true);
  const Vector3d centre(2.0, -1.0, 1.5), d(3.0, -2.0, 5.0);
  const double sigma = 6.0;  // mm
  const auto blob = [&](const Vector3d& p) {
    return std::exp(-(p - centre).squaredNorm() / (2 * sigma * sigma));
  };
  const VolumeF in = make_image(g, blob);
  const core::TetMesh mesh = test_box();
  const MatrixX3d u = d.transpose().replicate(mesh.num_nodes(), 1);
  const VolumeF out = warp_image(in, mesh, u);
  // Trilinear interpolation error ≤ Σ_d h_d²/8 · max|∂²f/∂x_d²| with max|∂²f/∂x²| = 1/σ² for the
  // Gaussian (h along each index axis; the rotated axes do not change the bound per axis).
  const double bound = g.spacing.squaredNorm() / 8.0 / (sigma * sigma) + 10 * FLOAT_EPS;
  int checked = 0;
  double worst = 0.0;
  for (int k = 0; k < g.size[2]; ++k)
    for (int j = 0; j < g.size[1]; ++j)
      for (int i = 0; i < g.size[0]; ++i) {
        const Vector3d y = g.index_to_world(Vector3d(i, j, k));
        if (!inside_box(y - d, 1e-6) || !inside_grid(g, y - d)) continue;
        worst = std::max(worst, std::abs(double(out.at(i, j, k)) - blob(y - d)));
        ++checked;
      }
  EXPECT_GT(checked, 5000);
  EXPECT_LE(worst, bound);
}

TEST(WarpImage, AffineDeformationOfALinearImageIsExact) {
  const ImageGeometry g = test_grid(/*rotated=*/true);
  const Vector3d gradient(0.7, -1.3, 2.1);
  const auto ramp = [&](const Vector3d& p) { return 50.0 + gradient.dot(p); };
  const VolumeF in = make_image(g, ramp);
  const core::TetMesh mesh = test_box();
  Matrix3d A;
  A << 0.05, -0.02, 0.03, 0.01, -0.04, 0.02, -0.03, 0.02, 0.06;
  const Vector3d b(1.0, -0.5, 2.0);
  MatrixX3d u(mesh.num_nodes(), 3);
  for (index_t n = 0; n < mesh.num_nodes(); ++n)
    u.row(n) = (A * mesh.nodes().row(n).transpose() + b).transpose();
  const VolumeF out = warp_image(in, mesh, u);
  const Matrix3d F_inv = (Matrix3d::Identity() + A).inverse();
  int checked = 0;
  double worst = 0.0;
  for (int k = 0; k < g.size[2]; ++k)
    for (int j = 0; j < g.size[1]; ++j)
      for (int i = 0; i < g.size[0]; ++i) {
        const Vector3d y = g.index_to_world(Vector3d(i, j, k));
        const Vector3d X = F_inv * (y - b);
        if (!inside_box(X, 1e-6) || !inside_grid(g, X)) continue;
        worst = std::max(worst, std::abs(double(out.at(i, j, k)) - ramp(X)));
        ++checked;
      }
  EXPECT_GT(checked, 5000);
  // Trilinear interpolation reproduces linear functions; what is left is float storage of values
  // up to ≈ 120 (a few ulp of the stored voxels).
  EXPECT_LE(worst, 120.0 * 4 * FLOAT_EPS);
}

TEST(WarpImage, OutsideTheMeshOnlyTheRigidPartApplies) {
  const ImageGeometry g = test_grid(/*rotated=*/false);
  const Vector3d gradient(0.7, -1.3, 2.1);
  const auto ramp = [&](const Vector3d& p) { return 50.0 + gradient.dot(p); };
  const VolumeF in = make_image(g, ramp);
  const core::TetMesh mesh = test_box();
  Eigen::Affine3d T =
      Eigen::Translation3d(1.5, -1.0, 0.5) * Eigen::AngleAxisd(0.15, Vector3d::UnitZ());
  WarpOptions options;
  options.rigid = T.matrix();
  // The mesh is translated (a non-rigid-part motion); only voxels outside it see T.
  const Vector3d d(3.0, -2.0, 5.0);
  const MatrixX3d u = d.transpose().replicate(mesh.num_nodes(), 1);
  const VolumeF out = warp_image(in, mesh, u, options);
  int outside = 0, inside = 0;
  double worst = 0.0, worst_inside = 0.0;
  for (int k = 0; k < g.size[2]; ++k)
    for (int j = 0; j < g.size[1]; ++j)
      for (int i = 0; i < g.size[0]; ++i) {
        const Vector3d y = g.index_to_world(Vector3d(i, j, k));
        if (inside_box(y - d, 1e-6) && inside_grid(g, y - d)) {
          worst_inside = std::max(worst_inside, std::abs(double(out.at(i, j, k)) - ramp(y - d)));
          ++inside;
        }
        const Vector3d X = T.inverse() * y;
        if (inside_box(y - d, -1e-6) || !inside_grid(g, X)) continue;
        worst = std::max(worst, std::abs(double(out.at(i, j, k)) - ramp(X)));
        ++outside;
      }
  EXPECT_GT(inside, 5000);
  EXPECT_LE(worst_inside, 120.0 * 4 * FLOAT_EPS);
  EXPECT_GT(outside, 20000);
  EXPECT_LE(worst, 120.0 * 4 * FLOAT_EPS);  // linear image: exact up to float storage
  // A voxel far outside: its pre-image is outside the input image, so it gets the fill value.
  options.outside_value = -7.0F;
  EXPECT_EQ(warp_image(in, mesh, u, options).at(g.size[0] - 1, 0, 0), -7.0F);
  // Non-rigid transforms are rejected.
  options.rigid(0, 0) = 2.0;
  expect_error([&] { (void)warp_image(in, mesh, u, options); }, {"rigid"});
}

TEST(DisplacementField, IsTheTranslationInsideTheMeshAndRigidOutside) {
  const ImageGeometry g = test_grid(/*rotated=*/true);
  const core::TetMesh mesh = test_box();
  const Vector3d d(3.0, -2.0, 5.0);
  const MatrixX3d u = d.transpose().replicate(mesh.num_nodes(), 1);
  DisplacementFieldOptions options;
  const Eigen::Affine3d T =
      Eigen::Translation3d(0.5, 0.0, -1.0) * Eigen::AngleAxisd(0.1, Vector3d::UnitX());
  options.rigid = T.matrix();
  const VolumeF field = displacement_field(mesh, u, g, options);
  ASSERT_EQ(field.components, 3);
  int inside = 0;
  double worst_in = 0.0, worst_out = 0.0;
  for (int k = 0; k < g.size[2]; ++k)
    for (int j = 0; j < g.size[1]; ++j)
      for (int i = 0; i < g.size[0]; ++i) {
        const Vector3d X = g.index_to_world(Vector3d(i, j, k));
        const Vector3d value(field.at(i, j, k, 0), field.at(i, j, k, 1), field.at(i, j, k, 2));
        if (inside_box(X, 1e-6)) {
          worst_in = std::max(worst_in, (value - d).norm());
          ++inside;
        } else if (!inside_box(X, -1e-6)) {
          worst_out = std::max(worst_out, (value - (T * X - X)).norm());
        }
      }
  EXPECT_GT(inside, 5000);
  EXPECT_LE(worst_in, 5.0 * 4 * FLOAT_EPS);    // float storage of |d| ≈ 6 mm
  EXPECT_LE(worst_out, 10.0 * 4 * FLOAT_EPS);  // |T X − X| ≤ ≈ 6 mm
}

/// An affine deformation u(X) = A X + b of the box mesh: φ is affine, its inverse known exactly.
struct AffineCase {
  Matrix3d A;
  Vector3d b;
  MatrixX3d u;
  [[nodiscard]] Vector3d inverse(const Vector3d& y) const {
    return (Matrix3d::Identity() + A).inverse() * (y - b);
  }
};

AffineCase affine_case(const core::TetMesh& mesh) {
  AffineCase c;
  c.A << 0.05, -0.02, 0.03, 0.01, -0.04, 0.02, -0.03, 0.02, 0.06;
  c.b = Vector3d(1.0, -0.5, 2.0);
  c.u.resize(mesh.num_nodes(), 3);
  for (index_t n = 0; n < mesh.num_nodes(); ++n)
    c.u.row(n) = (c.A * mesh.nodes().row(n).transpose() + c.b).transpose();
  return c;
}

Vector3d field_at(const VolumeF& f, int i, int j, int k) {
  return {f.at(i, j, k, 0), f.at(i, j, k, 1), f.at(i, j, k, 2)};
}

TEST(InverseDisplacementField, IsTheExactInverseInsideTheDeformedMeshAndRigidOutside) {
  const core::TetMesh mesh = test_box();
  const AffineCase c = affine_case(mesh);
  const Eigen::Affine3d T =
      Eigen::Translation3d(0.5, 0.0, -1.0) * Eigen::AngleAxisd(0.1, Vector3d::UnitX());
  DisplacementFieldOptions options;
  options.rigid = T.matrix();
  for (bool rotated : {false, true}) {
    SCOPED_TRACE(rotated ? "rotated grid" : "axis-aligned grid");
    const ImageGeometry g = test_grid(rotated);
    const VolumeF v = inverse_displacement_field(mesh, c.u, g, options);
    ASSERT_EQ(v.components, 3);
    int inside = 0, outside = 0;
    double worst_in = 0.0, worst_out = 0.0;
    for (int k = 0; k < g.size[2]; ++k)
      for (int j = 0; j < g.size[1]; ++j)
        for (int i = 0; i < g.size[0]; ++i) {
          const Vector3d y = g.index_to_world(Vector3d(i, j, k));
          const Vector3d X = c.inverse(y);  // the rest point the affine map sends to y
          if (inside_box(X, 1e-6)) {
            worst_in = std::max(worst_in, (field_at(v, i, j, k) - (X - y)).norm());
            ++inside;
          } else if (!inside_box(X, -1e-6)) {
            worst_out = std::max(worst_out, (field_at(v, i, j, k) - (T.inverse() * y - y)).norm());
            ++outside;
          }
        }
    EXPECT_GT(inside, 5000);
    EXPECT_GT(outside, 5000);
    // Barycentric interpolation of an affine map is exact; what is left is float storage of
    // values up to ≈ 5 mm (|X − y| here) and rounding in the index maps.
    EXPECT_LE(worst_in, 5.0 * 4 * FLOAT_EPS);
    EXPECT_LE(worst_out, 10.0 * 4 * FLOAT_EPS);  // |T⁻¹ y − y| ≤ ≈ 6 mm
  }
}

TEST(InverseDisplacementField, ComposedWithTheForwardFieldGivesTheIdentity) {
  // A non-affine deformation: X = y + v(y) must satisfy φ(X) = X + u(X) = y, with φ evaluated
  // on the mesh by barycentric coordinates (brute force over the tetrahedra).
  const core::TetMesh mesh = test_box();
  MatrixX3d u(mesh.num_nodes(), 3);
  for (index_t n = 0; n < mesh.num_nodes(); ++n) {
    const Vector3d X = mesh.nodes().row(n).transpose();
    u.row(n) = Eigen::RowVector3d(1.5 * std::sin(0.2 * X.y()), 0.8 * std::cos(0.15 * X.z()),
                                  0.05 * X.x() * X.y() / 10);
  }
  const ImageGeometry g = test_grid(/*rotated=*/true);
  // A rigid part far away: voxels outside the deformed mesh map 100 mm off, outside the box.
  DisplacementFieldOptions options;
  options.rigid = Eigen::Affine3d(Eigen::Translation3d(100.0, 0.0, 0.0)).matrix();
  const VolumeF v = inverse_displacement_field(mesh, u, g, options);
  // φ by brute force: find the rest tetrahedron containing X and interpolate u.
  const auto phi = [&](const Vector3d& X) -> std::optional<Vector3d> {
    for (index_t t = 0; t < mesh.num_tets(); ++t) {
      Matrix3d E;
      const auto node = [&](int a) {
        return Vector3d(mesh.nodes().row(mesh.tets()(t, a)).transpose());
      };
      E << node(1) - node(0), node(2) - node(0), node(3) - node(0);
      const Vector3d l = E.inverse() * (X - node(0));
      const Vector4d lambda(1.0 - l.sum(), l[0], l[1], l[2]);
      if (lambda.minCoeff() < -1e-9) continue;
      Vector3d x = X;
      for (int a = 0; a < 4; ++a) x += lambda[a] * u.row(mesh.tets()(t, a)).transpose();
      return x;
    }
    return std::nullopt;
  };
  int checked = 0;
  double worst = 0.0;
  for (int k = 0; k < g.size[2]; k += 3)
    for (int j = 0; j < g.size[1]; j += 3)
      for (int i = 0; i < g.size[0]; i += 3) {
        const Vector3d y = g.index_to_world(Vector3d(i, j, k));
        const Vector3d X = y + field_at(v, i, j, k);
        if (!inside_box(X, 1e-3)) continue;
        const auto x = phi(X);
        ASSERT_TRUE(x.has_value());
        worst = std::max(worst, (*x - y).norm());
        ++checked;
      }
  EXPECT_GT(checked, 200);
  // Exact map, float storage of |v| ≤ ≈ 3 mm: a few ulp.
  EXPECT_LE(worst, 3.0 * 8 * FLOAT_EPS);
}

TEST(DisplacementFields, TheExtensionContinuesTheMeshMapBeyondItsSurface) {
  const core::TetMesh mesh = test_box();
  const AffineCase c = affine_case(mesh);
  const ImageGeometry g = test_grid(/*rotated=*/true);
  DisplacementFieldOptions options;
  options.rigid =
      Eigen::Affine3d(Eigen::Translation3d(4.0, 0.0, 0.0)).matrix();  // far from the mesh map
  options.extension_mm = trilinear_support_mm(g);
  EXPECT_NEAR(options.extension_mm, g.spacing.norm(), 1e-12);
  const VolumeF forward = displacement_field(mesh, c.u, g, options);
  const VolumeF inverse = inverse_displacement_field(mesh, c.u, g, options);
  int ring_forward = 0, ring_inverse = 0, far = 0;
  double worst = 0.0, worst_far = 0.0;
  for (int k = 0; k < g.size[2]; ++k)
    for (int j = 0; j < g.size[1]; ++j)
      for (int i = 0; i < g.size[0]; ++i) {
        const Vector3d p = g.index_to_world(Vector3d(i, j, k));
        // Outside the box, closer to it than the extension (Euclidean distance to the box; 0.9:
        // the affine map stretches distances by up to ≈ 8 %, and the inverse is rasterised in the
        // deformed space).
        const auto band = [&](const Vector3d& X) {
          const Vector3d gap = (Eigen::Array3d(-12, -12, -10) - X.array())
                                   .max(X.array() - Eigen::Array3d(12, 12, 10))
                                   .max(0.0)
                                   .matrix();
          return gap.norm() > 1e-6 && gap.norm() < 0.9 * options.extension_mm;
        };
        if (band(p)) {  // forward: the affine u continued
          worst = std::max(worst, (field_at(forward, i, j, k) - (c.A * p + c.b)).norm());
          ++ring_forward;
        }
        const Vector3d X = c.inverse(p);
        if (band(X)) {  // inverse: the affine inverse continued (the deformed box is affine too)
          worst = std::max(worst, (field_at(inverse, i, j, k) - (X - p)).norm());
          ++ring_inverse;
        }
        if (!inside_box(p, -2.0 * options.extension_mm - 1.0)) {  // well beyond: rigid part
          worst_far =
              std::max(worst_far, (field_at(forward, i, j, k) - Vector3d(4.0, 0.0, 0.0)).norm());
          ++far;
        }
      }
  EXPECT_GT(ring_forward, 1000);
  EXPECT_GT(ring_inverse, 1000);
  EXPECT_GT(far, 1000);
  EXPECT_LE(worst, 5.0 * 4 * FLOAT_EPS);      // affine map continued exactly, float storage
  EXPECT_LE(worst_far, 4.0 * 4 * FLOAT_EPS);  // the rigid translation
  options.extension_mm = -1.0;
  expect_error([&] { (void)displacement_field(mesh, c.u, g, options); }, {"extension"});
}

TEST(DisplacementFields, OnePassEqualsTheTwoSeparateFieldsVoxelForVoxel) {
  // register writes displacement.nii.gz (no extension) and intraop_to_preop.nrrd (extended) from
  // one rasterisation: both must equal the separate displacement_field() calls exactly (same
  // float operations), for a non-affine displacement, a rotated grid, 1 and 3 threads.
  const core::TetMesh mesh = test_box();
  MatrixX3d u = affine_case(mesh).u;
  for (index_t n = 0; n < mesh.num_nodes(); ++n)
    u.row(n) += 0.3 * mesh.nodes().row(n).array().sin().matrix();
  const ImageGeometry g = test_grid(/*rotated=*/true);
  DisplacementFieldOptions options;
  options.rigid =
      (Eigen::Translation3d(2.0, -1.0, 0.5) * Eigen::AngleAxisd(0.05, Vector3d::UnitZ())).matrix();
  for (const int threads : {1, 3}) {
    SCOPED_TRACE("threads " + std::to_string(threads));
    options.threads = threads;
    options.extension_mm = trilinear_support_mm(g);
    const ForwardDisplacementFields both = displacement_fields(mesh, u, g, options);
    const VolumeF extended = displacement_field(mesh, u, g, options);
    options.extension_mm = 0.0;
    const VolumeF exact = displacement_field(mesh, u, g, options);
    ASSERT_EQ(both.exact.data.size(), exact.data.size());
    EXPECT_EQ(both.exact.data, exact.data);  // bit-identical: same operations
    EXPECT_EQ(both.extended.data, extended.data);
    // They differ only on the extension shell (some voxels, not none, not most).
    std::size_t differ = 0;
    for (std::size_t v = 0; v < exact.data.size(); v += 3)
      differ += (exact.data[v] != extended.data[v] || exact.data[v + 1] != extended.data[v + 1] ||
                 exact.data[v + 2] != extended.data[v + 2]);
    EXPECT_GT(differ, 100U);
    EXPECT_LT(differ, exact.data.size() / 3 / 4);
    // Without an extension both are the exact field.
    const ForwardDisplacementFields none = displacement_fields(mesh, u, g, options);
    EXPECT_EQ(none.exact.data, exact.data);
    EXPECT_EQ(none.extended.data, exact.data);
  }
  options.extension_mm = -1.0;
  expect_error([&] { (void)displacement_fields(mesh, u, g, options); }, {"extension"});
}

TEST(CoveringGrid, CoversThePointsOnTheVoxelLatticeOfTheModel) {
  const ImageGeometry like = test_grid(/*rotated=*/true);
  MatrixX3d points(3, 3);
  points << 40.0, -7.0, 3.0, -25.0, 31.0, -12.0, 5.0, 5.0, 50.0;
  const ImageGeometry g = covering_grid(like, points, /*margin_mm=*/2.0);
  EXPECT_TRUE(g.spacing.isApprox(like.spacing));
  EXPECT_TRUE(g.direction.isApprox(like.direction));
  for (index_t r = 0; r < points.rows(); ++r) {
    const Vector3d ijk = g.world_to_index(points.row(r).transpose());
    // Inside the grid with the margin (2 mm ≥ 2 / 1.3 voxels along every axis here).
    EXPECT_TRUE((ijk.array() >= 2.0 / like.spacing.array() - 1e-9).all()) << ijk.transpose();
    EXPECT_TRUE((ijk.array() <= (g.size.cast<double>() - Vector3d::Ones()).array() -
                                    2.0 / like.spacing.array() + 1e-9)
                    .all())
        << ijk.transpose();
  }
  // Voxel centres of the new grid are voxel centres of the old one (integer index offsets).
  const Vector3d offset = like.world_to_index(g.origin);
  EXPECT_LE((offset - offset.array().round().matrix()).norm(), 1e-9);
  expect_error([&] { (void)covering_grid(like, MatrixX3d(0, 3), 0.0); }, {"no points"});
}

TEST(WarpImage, RejectsBadInput) {
  const core::TetMesh mesh = test_box();
  const VolumeF in(test_grid(false));
  expect_error([&] { (void)warp_image(in, mesh, MatrixX3d::Zero(3, 3)); }, {"3 rows", "nodes"});
  expect_error([&] { (void)warp_image(VolumeF{}, mesh, MatrixX3d::Zero(mesh.num_nodes(), 3)); },
               {"empty"});
  MatrixX3d nan = MatrixX3d::Zero(mesh.num_nodes(), 3);
  nan(2, 1) = std::nan("");
  expect_error([&] { (void)displacement_field(mesh, nan, test_grid(false)); }, {"NaN"});
}

#ifdef NDEBUG
/// 256³ output voxels through a brain-sized mesh of ≈10k tetrahedra, 2 threads: the output has the
/// input's grid, and voxels far outside the mesh (the corners; the rigid part is the identity)
/// keep their values. Speed is measured by bench/bench_imaging.cpp, not here.
TEST(WarpImage, Warps256CubedVoxels) {
  ImageGeometry g;
  g.size = Eigen::Vector3i::Constant(256);
  g.spacing = Vector3d::Constant(0.8);
  g.origin = Vector3d::Constant(-0.5 * 255 * 0.8);
  VolumeF in(g);
  for (std::size_t v = 0; v < in.data.size(); ++v) in.data[v] = float(v % 1000);
  const core::TetMesh mesh = data_synth::make_ellipsoid_mesh(Vector3d(70, 85, 60), /*cells=*/12);
  MatrixX3d u(mesh.num_nodes(), 3);
  for (index_t n = 0; n < mesh.num_nodes(); ++n)
    u.row(n) = 0.05 * mesh.nodes().row(n) + Eigen::RowVector3d(1, 2, -1);
  const VolumeF out = warp_image(in, mesh, u);
  ASSERT_EQ(out.data.size(), in.data.size());
  EXPECT_EQ(out.geometry.size, g.size);
  for (const int c : {0, 255})
    for (const int b : {0, 255})
      for (const int a : {0, 255})
        EXPECT_EQ(out.at(a, b, c), in.at(a, b, c));  // ≥ 60 mm outside the mesh
  // Inside the mesh the image moves: some voxel near the centre changes.
  int changed = 0;
  for (int i = 118; i < 138; ++i) changed += out.at(i, 128, 128) != in.at(i, 128, 128);
  EXPECT_GT(changed, 10);
}
#endif

}  // namespace
}  // namespace brainshift::imaging
