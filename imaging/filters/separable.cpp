#include "imaging/filters/separable.hpp"

#include "core/error.hpp"
#include "imaging/filters/parallel.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

namespace brainshift::imaging::filters {
namespace {

/// out[t] of one line where the window reaches a missing sample (an end or a non-finite value).
double filter_sample(const std::vector<double>& line, int t, const std::vector<double>& kernel,
                     MissingData missing) {
  const int r = int(kernel.size() / 2);
  const int len = int(line.size());
  double sum = 0.0;
  double used = 0.0;   // weight on the samples that entered the sum
  double total = 0.0;  // weight within the line
  bool beyond = false;
  for (int d = -r; d <= r; ++d) {
    const int s = t + d;
    const double k = kernel[std::size_t(d + r)];
    if (s < 0 || s >= len) {
      beyond = true;
      if (missing == MissingData::CLAMP) sum += k * line[std::size_t(std::clamp(s, 0, len - 1))];
      continue;  // ZERO, RENORMALISE: left out; NAN_RESULT: NaN below
    }
    total += k;
    const double v = line[std::size_t(s)];
    if (!std::isfinite(v) && (missing == MissingData::ZERO || missing == MissingData::RENORMALISE))
      continue;
    sum += k * v;
    used += k;
  }
  if (missing == MissingData::NAN_RESULT && beyond) return std::numeric_limits<double>::quiet_NaN();
  if (missing == MissingData::RENORMALISE)
    return used > 0.0 && used >= 0.5 * total ? sum / used
                                             : std::numeric_limits<double>::quiet_NaN();
  return sum;
}

}  // namespace

void filter_axis(std::vector<float>& data, const Eigen::Vector3i& n, int axis,
                 const std::vector<double>& kernel, MissingData missing) {
  BS_VERIFY(axis >= 0 && axis <= 2, "filter_axis: axis must be 0, 1 or 2, got " << axis);
  BS_VERIFY(n.minCoeff() >= 1 && data.size() == std::size_t(n.cast<std::int64_t>().prod()),
            "filter_axis: " << data.size() << " values for a grid of " << n.transpose());
  BS_VERIFY(kernel.size() % 2 == 1,
            "filter_axis: the kernel has " << kernel.size() << " weights, expected an odd number");
  const int r = int(kernel.size() / 2);
  const int len = n[axis];
  double kernel_sum = 0.0;
  for (const double k : kernel) kernel_sum += k;
  const std::int64_t stride[3] = {1, n[0], std::int64_t(n[0]) * n[1]};
  /// One output sample of a line held in `line` (len values): the window's sum where it lies
  /// within the line and meets only finite samples, else filter_sample().
  const auto finish = [&](double out, bool interior, const std::vector<double>& line, int t) {
    if (interior) {
      // A finite sum means every sample was finite (0·∞ and ∞ − ∞ are NaN).
      if (std::isfinite(out)) return missing == MissingData::RENORMALISE ? out / kernel_sum : out;
      if (missing == MissingData::CLAMP || missing == MissingData::NAN_RESULT) return out;
    }
    return filter_sample(line, t, kernel, missing);
  };
  if (axis == 0) {
    // Lines are contiguous: one at a time, in parallel over the planes.
    parallel_for(n[2], [&](int k0, int k1) {
      std::vector<double> line(static_cast<std::size_t>(len));
      for (int k = k0; k < k1; ++k)
        for (int j = 0; j < n[1]; ++j) {
          float* x0 = &data[std::size_t(std::int64_t(j) * stride[1] + std::int64_t(k) * stride[2])];
          for (int t = 0; t < len; ++t) line[std::size_t(t)] = x0[t];
          for (int t = 0; t < len; ++t) {
            double out = 0.0;
            const bool interior = t >= r && t < len - r;
            if (interior) {
              const double* x = &line[std::size_t(t - r)];
              for (int d = 0; d <= 2 * r; ++d) out += kernel[std::size_t(d)] * x[d];
            }
            x0[t] = float(finish(out, interior, line, t));
          }
        }
    });
    return;
  }
  // Along y or z the lines of neighbouring x are neighbours in memory: `block` of them at once,
  // each output computed with the same operations in the same order as one line alone (so the
  // result is the same to the bit), with contiguous reads and a loop over x the compiler
  // vectorises. In parallel over the remaining axis.
  constexpr int block = 16;
  const int other = axis == 1 ? 2 : 1;
  const std::int64_t step = stride[axis];
  parallel_for(n[other], [&](int o0, int o1) {
    std::vector<double> lines(static_cast<std::size_t>(len) * block);
    std::vector<double> line(static_cast<std::size_t>(len));
    for (int o = o0; o < o1; ++o)
      for (int i0 = 0; i0 < n[0]; i0 += block) {
        const int width = std::min(block, n[0] - i0);
        float* x0 = &data[std::size_t(i0 + std::int64_t(o) * stride[other])];
        for (int t = 0; t < len; ++t)
          for (int b = 0; b < width; ++b)
            lines[std::size_t(t) * block + std::size_t(b)] = x0[t * step + b];
        // The interior, where the window lies within the lines: every lane at once.
        bool unfinished[block] = {};
        for (int t = r; t < len - r; ++t) {
          alignas(64) double out[block] = {};  // local: no aliasing with `lines`
          for (int d = 0; d <= 2 * r; ++d) {
            const double w = kernel[std::size_t(d)];
            const double* x = &lines[std::size_t(t - r + d) * block];
            for (int b = 0; b < block; ++b) out[b] += w * x[b];
          }
          for (int b = 0; b < width; ++b) {
            const double o_b = out[b];
            if (std::isfinite(o_b))
              x0[t * step + b] =
                  float(missing == MissingData::RENORMALISE ? o_b / kernel_sum : o_b);
            else
              unfinished[b] = true;  // a non-finite sample: the line alone below
          }
        }
        // The ends (and the lines with non-finite samples) one line at a time.
        for (int b = 0; b < width; ++b) {
          for (int u = 0; u < len; ++u)
            line[std::size_t(u)] = lines[std::size_t(u) * block + std::size_t(b)];
          for (int t = 0; t < len; ++t) {
            const bool interior = t >= r && t < len - r;
            if (interior && !unfinished[b]) continue;
            double o_b = 0.0;
            if (interior) {
              const double* x = &line[std::size_t(t - r)];
              for (int d = 0; d <= 2 * r; ++d) o_b += kernel[std::size_t(d)] * x[d];
            }
            x0[t * step + b] = float(finish(o_b, interior, line, t));
          }
        }
      }
  });
}

}  // namespace brainshift::imaging::filters
