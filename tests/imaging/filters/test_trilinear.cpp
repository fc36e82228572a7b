// The trilinear sampler and its missing-data policies against closed forms (imaging/filters).

#include "imaging/filters/trilinear.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

namespace brainshift::imaging::filters {
namespace {

/// f(i, j, k) = 2 + 3i − 1.5j + 0.25k: trilinear interpolation reproduces it exactly.
double linear(const Vector3d& x) { return 2.0 + 3.0 * x[0] - 1.5 * x[1] + 0.25 * x[2]; }

VolumeF linear_volume(const Eigen::Vector3i& n) {
  ImageGeometry g;
  g.size = n;
  VolumeF v(g, 2, 0.0F);
  for (int k = 0; k < n[2]; ++k)
    for (int j = 0; j < n[1]; ++j)
      for (int i = 0; i < n[0]; ++i) {
        v.at(i, j, k, 0) = float(linear(Vector3d(i, j, k)));
        v.at(i, j, k, 1) = float(-linear(Vector3d(i, j, k)));
      }
  return v;
}

constexpr MissingData all_policies[] = {MissingData::ZERO, MissingData::CLAMP,
                                        MissingData::NAN_RESULT, MissingData::RENORMALISE};

// Float storage and output: |f| ≤ 20 here, so 1e-5 is a few float ulps.
constexpr double float_tol = 1e-5;

TEST(Trilinear, ReproducesALinearFieldForEveryPolicy) {
  const VolumeF v = linear_volume({5, 4, 3});
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int s = 0; s < 200; ++s) {
    const Vector3d x(4 * u(rng), 3 * u(rng), 2 * u(rng));  // between the outer centres
    for (const MissingData m : all_policies) {
      EXPECT_NEAR(sample_trilinear(v, x, m), linear(x), float_tol);
      EXPECT_NEAR(sample_trilinear(v, x, m, /*component=*/1), -linear(x), float_tol);
    }
  }
  // Voxel centres: the stored value exactly (weights 1 and 0).
  EXPECT_EQ(sample_trilinear(v, Vector3d(3, 2, 1), MissingData::NAN_RESULT), v.at(3, 2, 1));
}

TEST(Trilinear, HalfVoxelBandIsTheBorderAndBeyondFollowsThePolicy) {
  const VolumeF v = linear_volume({5, 4, 3});
  const Vector3d band(-0.4, 1.5, 2.3);    // within half a voxel of the outer centres
  const Vector3d beyond(-0.7, 1.5, 1.0);  // farther out along i
  const double border = linear(Vector3d(0.0, 1.5, 2.0));
  for (const MissingData m : all_policies) {
    EXPECT_NEAR(sample_trilinear(v, band, m), border, float_tol);  // clamped onto the centres
  }
  EXPECT_EQ(sample_trilinear(v, beyond, MissingData::ZERO), 0.0F);
  EXPECT_NEAR(sample_trilinear(v, beyond, MissingData::CLAMP), linear(Vector3d(0, 1.5, 1.0)),
              float_tol);  // the nearest point of the grid
  EXPECT_TRUE(std::isnan(sample_trilinear(v, beyond, MissingData::NAN_RESULT)));
  EXPECT_TRUE(std::isnan(sample_trilinear(v, beyond, MissingData::RENORMALISE)));
  const Vector3d nan_index(std::numeric_limits<double>::quiet_NaN(), 1, 1);
  EXPECT_EQ(sample_trilinear(v, nan_index, MissingData::ZERO), 0.0F);
  EXPECT_TRUE(std::isnan(sample_trilinear(v, nan_index, MissingData::CLAMP)));
  EXPECT_FALSE(on_sampling_grid(v.geometry, nan_index));
  EXPECT_TRUE(on_sampling_grid(v.geometry, band));
  EXPECT_FALSE(on_sampling_grid(v.geometry, beyond));
}

TEST(Trilinear, NanVoxelFollowsThePolicy) {
  VolumeF v = linear_volume({5, 4, 3});
  const float stored = v.at(2, 1, 1);
  v.at(2, 1, 1) = std::numeric_limits<float>::quiet_NaN();
  for (const double w_nan : {0.3, 0.7}) {
    // Along i only, between voxels (1,1,1) and (2,1,1): the NaN voxel has weight w_nan.
    const Vector3d x(1.0 + w_nan, 1.0, 1.0);
    const double f = linear(x);
    // ZERO: the NaN voxel counts as 0, i.e. f minus its weighted value.
    EXPECT_NEAR(sample_trilinear(v, x, MissingData::ZERO), f - w_nan * stored, float_tol);
    EXPECT_TRUE(std::isnan(sample_trilinear(v, x, MissingData::CLAMP)));
    EXPECT_TRUE(std::isnan(sample_trilinear(v, x, MissingData::NAN_RESULT)));
    // RENORMALISE: the remaining voxel alone (weight 1 − w_nan), missing when below one half.
    const float r = sample_trilinear(v, x, MissingData::RENORMALISE);
    if (w_nan < 0.5)
      EXPECT_NEAR(r, (f - w_nan * stored) / (1.0 - w_nan), float_tol);
    else
      EXPECT_TRUE(std::isnan(r));
  }
  // A corner of zero weight is not used by RENORMALISE (at the centre of (1,1,1)).
  EXPECT_EQ(sample_trilinear(v, Vector3d(1, 1, 1), MissingData::RENORMALISE), v.at(1, 1, 1));
}

TEST(Trilinear, OneVoxelAxisIsConstant) {
  const VolumeF v = linear_volume({4, 1, 3});
  for (const MissingData m : all_policies) {
    // j is the single voxel: any j within the band gives the j = 0 value.
    EXPECT_NEAR(sample_trilinear(v, Vector3d(1.25, 0.4, 0.5), m), linear(Vector3d(1.25, 0, 0.5)),
                float_tol);
  }
}

}  // namespace
}  // namespace brainshift::imaging::filters
