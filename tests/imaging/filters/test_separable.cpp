// One separable filter pass and its missing-data policies against brute force (imaging/filters).

#include "core/error.hpp"
#include "imaging/filters/separable.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

namespace brainshift::imaging::filters {
namespace {

const std::vector<double> kernel = {0.1, 0.2, 0.4, 0.2, 0.1};  // r = 2, sum 1

/// Brute force along x of a single line, for every policy (the header's definitions).
std::vector<double> reference(const std::vector<float>& x, MissingData m) {
  const int len = int(x.size());
  std::vector<double> out(x.size());
  for (int t = 0; t < len; ++t) {
    double sum = 0, used = 0, total = 0;
    bool beyond = false;
    for (int d = -2; d <= 2; ++d) {
      const double k = kernel[std::size_t(d + 2)];
      const int s = t + d;
      const bool inside = s >= 0 && s < len;
      beyond = beyond || !inside;
      if (inside) total += k;
      double v = inside
                     ? x[std::size_t(s)]
                     : (m == MissingData::CLAMP ? x[std::size_t(std::clamp(s, 0, len - 1))] : 0.0);
      if (!inside && m != MissingData::CLAMP) continue;
      if (!std::isfinite(v) && (m == MissingData::ZERO || m == MissingData::RENORMALISE)) continue;
      sum += k * v;
      used += k;
    }
    out[std::size_t(t)] = m == MissingData::NAN_RESULT && beyond ? std::nan("")
                          : m == MissingData::RENORMALISE
                              ? (used >= 0.5 * total ? sum / used : std::nan(""))
                              : sum;
  }
  return out;
}

void expect_matches(const std::vector<float>& line, MissingData m) {
  std::vector<float> data = line;
  filter_axis(data, Eigen::Vector3i(int(line.size()), 1, 1), 0, kernel, m);
  const std::vector<double> want = reference(line, m);
  for (std::size_t t = 0; t < line.size(); ++t) {
    if (std::isnan(want[t])) {
      EXPECT_TRUE(std::isnan(data[t])) << "t " << t;
    } else {
      // Float output of a double sum of values ≤ 10: a few float ulps.
      EXPECT_NEAR(data[t], want[t], 1e-5) << "t " << t << " policy " << int(m);
    }
  }
}

TEST(SeparableFilter, EveryPolicyMatchesBruteForce) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(-10.0F, 10.0F);
  std::vector<float> line(12);
  for (float& v : line) v = u(rng);
  for (const MissingData m :
       {MissingData::ZERO, MissingData::CLAMP, MissingData::NAN_RESULT, MissingData::RENORMALISE}) {
    expect_matches(line, m);
    std::vector<float> holes = line;
    holes[5] = std::numeric_limits<float>::quiet_NaN();
    holes[6] = std::numeric_limits<float>::quiet_NaN();
    holes[0] = std::numeric_limits<float>::quiet_NaN();
    expect_matches(holes, m);
  }
}

TEST(SeparableFilter, RenormaliseKeepsAConstantAtTheFacesAndAlongEveryAxis) {
  const Eigen::Vector3i n(4, 5, 6);
  for (int axis = 0; axis < 3; ++axis) {
    std::vector<float> data(std::size_t(n.prod()), 3.5F);
    filter_axis(data, n, axis, kernel, MissingData::RENORMALISE);
    for (const float v : data) EXPECT_NEAR(v, 3.5, 1e-6);  // normalised weights: rounding only
  }
}

TEST(SeparableFilter, RejectsBadArguments) {
  std::vector<float> data(10, 1.0F);
  EXPECT_THROW(filter_axis(data, Eigen::Vector3i(5, 1, 1), 0, kernel, MissingData::ZERO), Error);
  EXPECT_THROW(filter_axis(data, Eigen::Vector3i(10, 1, 1), 3, kernel, MissingData::ZERO), Error);
  EXPECT_THROW(filter_axis(data, Eigen::Vector3i(10, 1, 1), 0, {0.5, 0.5}, MissingData::ZERO),
               Error);
}

/// `data` on grid n with axes a and b exchanged (a, b ∈ {0, 1, 2}).
std::vector<float> swap_axes(const std::vector<float>& data, const Eigen::Vector3i& n, int a,
                             int b) {
  Eigen::Vector3i m = n;
  std::swap(m[a], m[b]);
  std::vector<float> out(data.size());
  for (int k = 0; k < n[2]; ++k)
    for (int j = 0; j < n[1]; ++j)
      for (int i = 0; i < n[0]; ++i) {
        Eigen::Vector3i p(i, j, k);
        std::swap(p[a], p[b]);
        out[std::size_t(p[0] + std::int64_t(m[0]) * (p[1] + std::int64_t(m[1]) * p[2]))] =
            data[std::size_t(i + std::int64_t(n[0]) * (j + std::int64_t(n[1]) * k))];
      }
  return out;
}

TEST(SeparableFilter, StridedAxesEqualTheContiguousAxisToTheBit) {
  // Lines along y and z are filtered 16 neighbouring x at a time (vectorised), lines along x one
  // at a time: filtering along y (z) must give exactly what filtering the transposed array along
  // x gives, for every missing-data policy, with non-finite samples, ends within the kernel's
  // reach, partial blocks (x = 37 = 2·16 + 5) and lines shorter than the kernel (y = 4 < 7).
  const Eigen::Vector3i n(37, 4, 23);
  std::vector<float> data(std::size_t(n.prod()));
  std::mt19937 rng(21);
  std::uniform_real_distribution<float> u(-20.0F, 100.0F);
  for (float& x : data) x = u(rng);
  for (std::size_t i = 5; i < data.size(); i += 97) data[i] = std::nanf("");
  for (std::size_t i = 11; i < data.size(); i += 389)
    data[i] = std::numeric_limits<float>::infinity();
  const std::vector<double> wide{0.05, 0.1, 0.2, 0.3, 0.2, 0.1, 0.05};
  for (const MissingData missing :
       {MissingData::ZERO, MissingData::CLAMP, MissingData::NAN_RESULT, MissingData::RENORMALISE})
    for (const int axis : {1, 2}) {
      SCOPED_TRACE("policy " + std::to_string(int(missing)) + ", axis " + std::to_string(axis));
      std::vector<float> strided = data;
      filter_axis(strided, n, axis, wide, missing);
      Eigen::Vector3i m = n;
      std::swap(m[0], m[axis]);
      std::vector<float> contiguous = swap_axes(data, n, 0, axis);
      filter_axis(contiguous, m, 0, wide, missing);
      contiguous = swap_axes(contiguous, m, 0, axis);
      int differing = 0;
      for (std::size_t v = 0; v < data.size(); ++v) {
        const bool same =
            std::isnan(strided[v]) ? std::isnan(contiguous[v]) : strided[v] == contiguous[v];
        differing += same ? 0 : 1;
      }
      EXPECT_EQ(differing, 0);
    }
}

TEST(SeparableFilter, LinesOfZerosAreLeftOnlyWhereTheFilterKeepsThemZero) {
  // Lines (and blocks of 16 lines along y and z) whose samples are all +0.0 are skipped where the
  // policy filters such a line to +0.0: every line of a volume with zero regions (outside a
  // block, a whole block, lines mixing zeros and values) must still equal brute force, and under
  // NAN_RESULT a zero line's ends must come out NaN, not be left at zero.
  const Eigen::Vector3i n(37, 21, 19);  // x: two full blocks of 16 and a partial one
  std::vector<float> data(std::size_t(n.prod()), 0.0F);
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-5.0F, 40.0F);
  for (int k = 4; k < 12; ++k)
    for (int j = 3; j < 14; ++j)
      for (int i = 18; i < 30; ++i)  // the second block of x only, and part of it
        data[std::size_t(i + std::int64_t(n[0]) * (j + std::int64_t(n[1]) * k))] = u(rng);
  data[std::size_t(2 + std::int64_t(n[0]) * (20 + std::int64_t(n[1]) * 18))] = -0.0F;
  for (const MissingData missing :
       {MissingData::ZERO, MissingData::CLAMP, MissingData::NAN_RESULT, MissingData::RENORMALISE})
    for (const int axis : {0, 1, 2}) {
      SCOPED_TRACE("policy " + std::to_string(int(missing)) + ", axis " + std::to_string(axis));
      std::vector<float> out = data;
      filter_axis(out, n, axis, kernel, missing);
      const std::int64_t stride[3] = {1, n[0], std::int64_t(n[0]) * n[1]};
      const int a = (axis + 1) % 3, b = (axis + 2) % 3;
      int wrong = 0, zero_ends_nan = 0;
      for (int p = 0; p < n[a]; ++p)
        for (int q = 0; q < n[b]; ++q) {
          const std::int64_t start = p * stride[a] + q * stride[b];
          std::vector<float> line(std::size_t(n[axis]));
          for (int t = 0; t < n[axis]; ++t)
            line[std::size_t(t)] = data[std::size_t(start + t * stride[axis])];
          const std::vector<double> want = reference(line, missing);
          const bool zeros =
              std::all_of(line.begin(), line.end(), [](float v) { return v == 0.0F; });
          for (int t = 0; t < n[axis]; ++t) {
            const float got = out[std::size_t(start + t * stride[axis])];
            const double w = want[std::size_t(t)];
            // A float result of a double sum of values ≤ 40: a few float ulps.
            const bool ok = std::isnan(w) ? std::isnan(got) : std::abs(got - w) <= 1e-4;
            wrong += ok ? 0 : 1;
            if (zeros && std::isnan(got)) ++zero_ends_nan;
          }
        }
      EXPECT_EQ(wrong, 0);
      // NAN_RESULT: the two kernel radii at each end of every all-zero line are NaN.
      if (missing == MissingData::NAN_RESULT) {
        EXPECT_GT(zero_ends_nan, 0);
      } else {
        EXPECT_EQ(zero_ends_nan, 0);
      }
    }
}

}  // namespace
}  // namespace brainshift::imaging::filters
