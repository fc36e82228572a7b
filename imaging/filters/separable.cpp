#include "imaging/filters/separable.hpp"

#include "core/error.hpp"
#include "imaging/filters/parallel.hpp"

#include <algorithm>
#include <bit>
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

/// Lines filtered side by side along y and z.
constexpr int lanes = 16;

/// out[b] += Σ_d kernel[d] · x[d · lanes + b] for the `lanes` lanes b, over d in order: per
/// lane the operations of one line alone. Also compiled for AVX2 and chosen when the processor
/// has it: four lanes per instruction instead of two, the same multiplications and additions
/// rounded the same way (AVX2 without FMA: nothing is fused), so the same result to the bit.
__attribute__((target_clones("avx2", "default"))) void accumulate_lanes(const double* kernel,
                                                                        int taps, const double* x,
                                                                        double* out) {
  for (int d = 0; d < taps; ++d) {
    const double w = kernel[d];
    const double* xd = x + std::ptrdiff_t(d) * lanes;
    for (int b = 0; b < lanes; ++b) out[b] += w * xd[b];
  }
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
  // A line of +0.0 samples (every bit zero) filters to itself under most policies (the window's
  // sum is +0.0, divided by a positive weight): whether it does here is found once, by filtering
  // such a line with the general code below, and then such lines are left as they are. Outside
  // an ultrasound sector a volume is zeros (68 % of the voxels of a 16 M-voxel Doppler sweep).
  // NAN_RESULT's ends, and a renormalised window of no weight, are not zero: nothing is skipped.
  const bool zero_lines_stay = [&] {
    const std::vector<double> zeros(static_cast<std::size_t>(len), 0.0);
    for (int t = 0; t < len; ++t) {
      double out = 0.0;
      const bool interior = t >= r && t < len - r;
      if (interior)
        for (int d = 0; d <= 2 * r; ++d)
          out += kernel[std::size_t(d)] * zeros[std::size_t(t - r + d)];
      if (std::bit_cast<std::uint32_t>(float(finish(out, interior, zeros, t))) != 0) return false;
    }
    return true;
  }();
  // Within a line, an interior output whose whole window is +0.0 is +0.0 under every policy
  // whose interior sum of zeros stays +0.0 (all but a renormalisation by a weight sum ≤ 0): such
  // outputs are left as they are (their sample is +0.0 already). `run[t]`: how many +0.0
  // samples end at t.
  const bool zero_windows_stay =
      std::bit_cast<std::uint32_t>(
          float(missing == MissingData::RENORMALISE ? 0.0 / kernel_sum : 0.0)) == 0;
  const int window = 2 * r + 1;
  if (axis == 0) {
    // Lines are contiguous: one at a time, in parallel over the planes.
    parallel_for(n[2], [&](int k0, int k1) {
      std::vector<double> line(static_cast<std::size_t>(len));
      std::vector<int> run(static_cast<std::size_t>(len));
      for (int k = k0; k < k1; ++k)
        for (int j = 0; j < n[1]; ++j) {
          float* x0 = &data[std::size_t(std::int64_t(j) * stride[1] + std::int64_t(k) * stride[2])];
          if (zero_lines_stay) {
            std::uint32_t bits = 0;
            for (int t = 0; t < len; ++t) bits |= std::bit_cast<std::uint32_t>(x0[t]);
            if (bits == 0) continue;
          }
          for (int t = 0; t < len; ++t) {
            line[std::size_t(t)] = x0[t];
            run[std::size_t(t)] = std::bit_cast<std::uint32_t>(x0[t]) != 0 ? 0
                                  : t == 0                                 ? 1
                                           : run[std::size_t(t - 1)] + 1;
          }
          for (int t = 0; t < len; ++t) {
            double out = 0.0;
            const bool interior = t >= r && t < len - r;
            if (interior && zero_windows_stay && run[std::size_t(t + r)] >= window) continue;
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
  constexpr int block = lanes;
  const int other = axis == 1 ? 2 : 1;
  const std::int64_t step = stride[axis];
  parallel_for(n[other], [&](int o0, int o1) {
    std::vector<double> lines(static_cast<std::size_t>(len) * block);
    std::vector<double> line(static_cast<std::size_t>(len));
    std::vector<int> run(static_cast<std::size_t>(len));  // of rows of `width` +0.0 samples
    for (int o = o0; o < o1; ++o)
      for (int i0 = 0; i0 < n[0]; i0 += block) {
        const int width = std::min(block, n[0] - i0);
        float* x0 = &data[std::size_t(i0 + std::int64_t(o) * stride[other])];
        std::uint32_t bits = 0;
        for (int t = 0; t < len; ++t) {
          std::uint32_t row = 0;
          for (int b = 0; b < width; ++b) {
            row |= std::bit_cast<std::uint32_t>(x0[t * step + b]);
            lines[std::size_t(t) * block + std::size_t(b)] = x0[t * step + b];
          }
          bits |= row;
          run[std::size_t(t)] = row != 0 ? 0 : t == 0 ? 1 : run[std::size_t(t - 1)] + 1;
        }
        if (bits == 0 && zero_lines_stay) continue;  // `width` lines of +0.0
        // The interior, where the window lies within the lines: every lane at once.
        bool unfinished[block] = {};
        for (int t = r; t < len - r; ++t) {
          if (zero_windows_stay && run[std::size_t(t + r)] >= window) continue;
          alignas(64) double out[block] = {};  // local: no aliasing with `lines`
          accumulate_lanes(kernel.data(), 2 * r + 1, &lines[std::size_t(t - r) * block], out);
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
