// Separable Gaussian (derivative) filtering and the Frangi vesselness (imaging/filters).

#include "expect_error.hpp"

#include "imaging/filters/gaussian.hpp"
#include "imaging/filters/order_statistic.hpp"
#include "imaging/filters/vesselness.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

namespace brainshift::imaging::filters {
namespace {

ImageGeometry grid(const Eigen::Vector3i& n, const Vector3d& spacing) {
  ImageGeometry g;
  g.size = n;
  g.spacing = spacing;
  return g;
}

TEST(GaussianFilter, KernelsHaveTheirExactMoments) {
  for (const double s : {0.7, 1.0, 2.5}) {
    const auto k0 = gaussian_kernel(s, 0), k1 = gaussian_kernel(s, 1), k2 = gaussian_kernel(s, 2);
    const int r = int(k0.size() / 2);
    double m0 = 0, m1 = 0, m2 = 0, z2 = 0;
    for (int t = -r; t <= r; ++t) {
      m0 += k0[std::size_t(t + r)];
      m1 += t * k1[std::size_t(t + r)];
      m2 += t * t * k2[std::size_t(t + r)];
      z2 += k2[std::size_t(t + r)];
    }
    // Normalised by construction: rounding only.
    EXPECT_NEAR(m0, 1.0, 1e-12);
    EXPECT_NEAR(m1, -1.0, 1e-12);
    EXPECT_NEAR(m2, 2.0, 1e-12);
    EXPECT_NEAR(z2, 0.0, 1e-12);
  }
  EXPECT_TRUE(gaussian_kernel(0.01, 0).empty());  // narrower than 1/20 voxel: the identity
}

TEST(GaussianFilter, DerivativesOfRampsAndParabolasAreExactInTheInterior) {
  const ImageGeometry g = grid({40, 30, 20}, {0.5, 0.8, 1.5});
  VolumeF ramp(g), parabola(g);
  for (int k = 0; k < g.size[2]; ++k)
    for (int j = 0; j < g.size[1]; ++j)
      for (int i = 0; i < g.size[0]; ++i) {
        const Vector3d p = g.index_to_world(Vector3d(i, j, k));
        ramp.at(i, j, k) = float(3.0 * p.x() - 2.0 * p.y() + 0.5 * p.z());
        parabola.at(i, j, k) = float(0.25 * p.y() * p.y());
      }
  const VolumeF dx = gaussian_filter(ramp, 1.2, {1, 0, 0});
  const VolumeF dy = gaussian_filter(ramp, 1.2, {0, 1, 0});
  const VolumeF dyy = gaussian_filter(parabola, 1.2, {0, 2, 0});
  const VolumeF smooth = gaussian_filter(ramp, 1.2);
  // Away from the faces (3σ), to float rounding of values up to ≈ 100: 1e-3 relative.
  for (int k = 3; k < 17; ++k)
    for (int j = 6; j < 24; ++j)
      for (int i = 8; i < 32; ++i) {
        EXPECT_NEAR(dx.at(i, j, k), 3.0, 2e-3);
        EXPECT_NEAR(dy.at(i, j, k), -2.0, 2e-3);
        EXPECT_NEAR(dyy.at(i, j, k), 0.5, 2e-3);
        EXPECT_NEAR(smooth.at(i, j, k), ramp.at(i, j, k), 1e-3 * 100);
      }
}

TEST(GaussianFilter, WhiteNoiseGainMatchesTheMeasuredReduction) {
  const ImageGeometry g = grid({64, 64, 64}, {0.8, 0.8, 0.8});
  VolumeF noise(g);
  std::mt19937 rng(3);
  std::normal_distribution<float> normal(0.0F, 1.0F);
  for (float& v : noise.data) v = normal(rng);
  const VolumeF f = gaussian_filter(noise, 0.6);
  double sum2 = 0.0;
  std::int64_t n = 0;
  for (int k = 4; k < 60; ++k)
    for (int j = 4; j < 60; ++j)
      for (int i = 4; i < 60; ++i, ++n) sum2 += double(f.at(i, j, k)) * f.at(i, j, k);
  // 175k samples: the measured standard deviation is within 1 % of the truth; 3 % allowed.
  EXPECT_NEAR(std::sqrt(sum2 / double(n)), gaussian_noise_gain(g, 0.6),
              0.03 * gaussian_noise_gain(g, 0.6));
}

TEST(GaussianFilter, DownsampleMeansAndMaxima) {
  const ImageGeometry g = grid({5, 4, 3}, {1.0, 1.0, 2.0});
  VolumeF v(g);
  for (std::size_t i = 0; i < v.data.size(); ++i) v.data[i] = float(i);
  const VolumeF mean = downsample(v, {2, 2, 1});
  const VolumeF peak = downsample(v, {2, 2, 1}, true);
  ASSERT_EQ(mean.geometry.size, Eigen::Vector3i(3, 2, 3));
  EXPECT_FLOAT_EQ(mean.at(0, 0, 0), (0 + 1 + 5 + 6) / 4.0F);
  EXPECT_FLOAT_EQ(peak.at(0, 0, 0), 6.0F);
  EXPECT_FLOAT_EQ(mean.at(2, 1, 2),
                  56.5F);  // voxels 54 and 59: a block of 1 × 2 × 1 at the far faces
  EXPECT_FLOAT_EQ(peak.at(2, 1, 2), 59.0F);
  // Block centres: block (0,0,0) covers voxels 0 and 1 along i, j.
  EXPECT_LT((mean.geometry.index_to_world(Vector3d::Zero()) - Vector3d(0.5, 0.5, 0.0)).norm(),
            1e-12);
  tests::expect_error([&] { downsample(v, {0, 1, 1}); }, {"factors"});
}

TEST(GaussianFilter, DownsampleOnThreadsEqualsOnePassToTheBit) {
  // Output planes are accumulated on several threads; each block's float sum must still be
  // formed in one pass's (k, j, i) order, so means and maxima equal a plain one-pass reference
  // exactly, on a grid with partial blocks (37 = 3·12 + 1 planes) and NaN voxels left out.
  const ImageGeometry g = grid({23, 17, 37}, {0.4, 0.4, 0.4});
  VolumeF v(g);
  std::mt19937 rng(9);
  std::uniform_real_distribution<float> u(-50.0F, 300.0F);
  for (float& x : v.data) x = u(rng);
  for (std::size_t i = 0; i < v.data.size(); i += 13) v.data[i] = std::nanf("");
  const Eigen::Vector3i f(2, 3, 3);
  for (const bool maximum : {false, true}) {
    SCOPED_TRACE(maximum ? "maxima" : "means");
    const VolumeF out = downsample(v, f, maximum);
    std::vector<float> ref(out.data.size(), 0.0F), count(out.data.size(), 0.0F);
    for (int k = 0; k < g.size[2]; ++k)
      for (int j = 0; j < g.size[1]; ++j)
        for (int i = 0; i < g.size[0]; ++i) {
          const float x = v.at(i, j, k);
          if (!std::isfinite(x)) continue;
          const auto o = std::size_t(out.geometry.linear_index(i / f[0], j / f[1], k / f[2]));
          ref[o] = maximum ? (count[o] == 0.0F ? x : std::max(ref[o], x)) : ref[o] + x;
          count[o] += 1.0F;
        }
    int differing = 0;
    for (std::size_t o = 0; o < ref.size(); ++o) {
      const float want = !maximum && count[o] > 0.0F ? ref[o] / count[o] : ref[o];
      differing += out.data[o] == want ? 0 : 1;
    }
    EXPECT_EQ(differing, 0);
  }
}

TEST(OrderStatistic, MedianWhereIsTheValueNthElementSelects) {
  // The histogram selection must give exactly the ⌊m/2⌋-th smallest of the kept finite values,
  // as std::nth_element does on the gathered values: negatives, ±0, ties in one histogram bin,
  // NaN and ±∞ (left out), and a subset chosen by the predicate.
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-1000.0F, 1000.0F);
  for (const int variant : {0, 1, 2}) {
    SCOPED_TRACE("variant " + std::to_string(variant));
    std::vector<float> x(100003);
    for (std::size_t i = 0; i < x.size(); ++i) {
      x[i] = variant == 0   ? u(rng)
             : variant == 1 ? float(int(u(rng)) % 3) * 0.0F + (i % 2 == 0 ? -0.0F : 0.0F)
                            : 1.0F + 1e-6F * float(i % 50);  // all in a few bins
      if (i % 101 == 0) x[i] = std::nanf("");
      if (i % 211 == 0)
        x[i] = i % 2 == 0 ? std::numeric_limits<float>::infinity()
                          : -std::numeric_limits<float>::infinity();
    }
    const auto keep = [](std::size_t v) { return v % 7 != 3; };
    std::vector<float> kept;
    for (std::size_t v = 0; v < x.size(); ++v)
      if (keep(v) && std::isfinite(x[v])) kept.push_back(x[v]);
    const auto mid = kept.begin() + std::ptrdiff_t(kept.size() / 2);
    std::nth_element(kept.begin(), mid, kept.end());
    const auto got = median_where(x.size(), keep, [&x](std::size_t v) { return x[v]; });
    ASSERT_TRUE(got.has_value());
    EXPECT_EQ(got->value, *mid);
    EXPECT_EQ(got->count, kept.size());
  }
  // Nothing kept, or nothing finite: no median.
  const std::vector<float> nan_only(10, std::nanf(""));
  EXPECT_FALSE(median_where(
      nan_only.size(), [](std::size_t) { return true; },
      [&](std::size_t v) { return nan_only[v]; }));
  EXPECT_FALSE(median_where(
      std::size_t(0), [](std::size_t) { return true; }, [](std::size_t) { return 0.0F; }));
}

TEST(Vesselness, TubesRespondPlatesAndBlobsDoNot) {
  const ImageGeometry g = grid({60, 60, 60}, {0.5, 0.5, 0.5});
  VolumeF image(g, 1, 0.0F);
  for (int k = 0; k < g.size[2]; ++k)
    for (int j = 0; j < g.size[1]; ++j)
      for (int i = 0; i < g.size[0]; ++i) {
        const Vector3d p = g.index_to_world(Vector3d(i, j, k));
        const bool tube =
            (Vector3d(p.x(), p.y(), 0) - Vector3d(7.5, 7.5, 0)).norm() <= 1.5;  // along z
        const bool plate = std::abs(p.x() - 22.0) <= 1.5;                       // normal x
        const bool blob = (p - Vector3d(15, 22, 15)).norm() <= 3.0;
        image.at(i, j, k) = tube || plate || blob ? 100.0F : 0.0F;
      }
  VesselnessOptions o;
  o.scales_mm = {1.0, 2.0};
  const VolumeF v = frangi_vesselness(image, o);
  const auto at = [&](const Vector3d& p) {
    const Vector3d ijk = g.world_to_index(p).array().round();
    return v.at(int(ijk[0]), int(ijk[1]), int(ijk[2]));
  };
  const float tube = at({7.5, 7.5, 15}), plate = at({22, 15, 15}), blob = at({15, 22, 15});
  // Frangi's measure: a tube scores near its structure term (≈ 0.5 or more here), a plate
  // (Ra ≈ 0) and a sphere (Rb ≈ 1: exp(−2) ≈ 0.14 at most) far less.
  EXPECT_GT(tube, 0.4F);
  EXPECT_LT(plate, 0.1F * tube);
  EXPECT_LT(blob, 0.3F * tube);
  for (const float x : v.data) {
    ASSERT_GE(x, 0.0F);
    ASSERT_LT(x, 1.0F);
  }
  VesselnessOptions bad;
  bad.scales_mm = {};
  tests::expect_error([&] { frangi_vesselness(image, bad); }, {"scales_mm"});
}

}  // namespace
}  // namespace brainshift::imaging::filters
