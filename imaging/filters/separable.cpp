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
  const int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
  // Lines in parallel, chunked by the slowest-varying other axis.
  parallel_for(n[a2], [&](int q0, int q1) {
    std::vector<double> line(static_cast<std::size_t>(len));
    for (int q = q0; q < q1; ++q)
      for (int p = 0; p < n[a1]; ++p) {
        const std::int64_t start = std::int64_t(p) * stride[a1] + std::int64_t(q) * stride[a2];
        const std::int64_t step = stride[axis];
        for (int t = 0; t < len; ++t) line[std::size_t(t)] = data[std::size_t(start + t * step)];
        for (int t = 0; t < len; ++t) {
          double out = 0.0;
          bool done = false;
          if (t >= r && t < len - r) {  // the window lies within the line
            const double* x = &line[std::size_t(t - r)];
            for (int d = 0; d <= 2 * r; ++d) out += kernel[std::size_t(d)] * x[d];
            // A finite sum means every sample was finite (0·∞ and ∞ − ∞ are NaN).
            if (std::isfinite(out)) {
              if (missing == MissingData::RENORMALISE) out /= kernel_sum;
              done = true;
            } else {
              done = missing == MissingData::CLAMP || missing == MissingData::NAN_RESULT;
            }
          }
          if (!done) out = filter_sample(line, t, kernel, missing);
          data[std::size_t(start + t * step)] = float(out);
        }
      }
  });
}

}  // namespace brainshift::imaging::filters
