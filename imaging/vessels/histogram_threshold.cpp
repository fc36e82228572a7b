#include "imaging/vessels/histogram_threshold.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace brainshift::imaging {
namespace {

struct Histogram {
  double low = 0.0;
  double width = 0.0;
  std::vector<double> counts;
};

std::optional<Histogram> histogram(const VolumeF& image, const HistogramOptions& options) {
  BS_VERIFY(image.components == 1,
            "a histogram threshold needs a one-component image, got " << image.components);
  BS_VERIFY(options.bins >= 2 && options.smoothing_half_width >= 0,
            "histogram needs ≥ 2 bins and a non-negative smoothing width, got "
                << options.bins << " and " << options.smoothing_half_width);
  float low = std::numeric_limits<float>::infinity(), high = -low;
  for (const float v : image.data)
    if (std::isfinite(v)) {
      low = std::min(low, v);
      high = std::max(high, v);
    }
  if (!(high > low)) return std::nullopt;
  Histogram h;
  h.low = low;
  h.width = (double(high) - double(low)) / options.bins;
  h.counts.assign(std::size_t(options.bins), 0.0);
  for (const float v : image.data)
    if (std::isfinite(v)) {
      const int b = std::min(options.bins - 1, int((double(v) - h.low) / h.width));
      h.counts[std::size_t(b)] += 1.0;
    }
  return h;
}

}  // namespace

std::optional<double> tissue_peak_threshold(const VolumeF& image, double tail_fraction,
                                            const HistogramOptions& options) {
  BS_VERIFY(tail_fraction > 0.0 && tail_fraction < 1.0,
            "tail fraction must lie in (0, 1), got " << tail_fraction);
  const auto h = histogram(image, options);
  if (!h) return std::nullopt;
  const int n = int(h->counts.size()), w = options.smoothing_half_width;
  std::vector<double> smooth(std::size_t(n), 0.0);
  for (int b = 0; b < n; ++b) {
    const int first = std::max(0, b - w), last = std::min(n - 1, b + w);
    for (int c = first; c <= last; ++c) smooth[std::size_t(b)] += h->counts[std::size_t(c)];
    smooth[std::size_t(b)] /= double(last - first + 1);
  }
  const auto mode = std::size_t(std::max_element(smooth.begin(), smooth.end()) - smooth.begin());
  const double limit = tail_fraction * smooth[mode];
  for (std::size_t b = mode + 1; b < smooth.size(); ++b)
    if (smooth[b] < limit) return h->low + double(b) * h->width;
  return std::nullopt;
}

std::optional<double> otsu_threshold(const VolumeF& image, const HistogramOptions& options) {
  const auto h = histogram(image, options);
  if (!h) return std::nullopt;
  double total = 0.0, total_moment = 0.0;
  for (std::size_t b = 0; b < h->counts.size(); ++b) {
    total += h->counts[b];
    total_moment += double(b) * h->counts[b];
  }
  double below = 0.0, below_moment = 0.0, best = -1.0;
  std::size_t best_bin = 0;
  for (std::size_t b = 0; b + 1 < h->counts.size(); ++b) {
    below += h->counts[b];
    below_moment += double(b) * h->counts[b];
    const double above = total - below;
    if (below <= 0.0 || above <= 0.0) continue;
    const double mean_below = below_moment / below;
    const double mean_above = (total_moment - below_moment) / above;
    const double between = below * above * (mean_below - mean_above) * (mean_below - mean_above);
    if (between > best) {
      best = between;
      best_bin = b;
    }
  }
  return h->low + double(best_bin + 1) * h->width;
}

}  // namespace brainshift::imaging
