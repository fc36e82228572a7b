#include "imaging/vessels/vessel_threshold.hpp"

#include "core/parallel.hpp"
#include "imaging/filters/gaussian.hpp"
#include "imaging/filters/order_statistic.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <sstream>
#include <vector>

namespace brainshift::imaging {
namespace {

double median_of(std::vector<float>& values) {
  const auto mid = values.begin() + std::ptrdiff_t(values.size() / 2);
  std::nth_element(values.begin(), mid, values.end());
  return *mid;
}

/// The passes over every voxel below run on this many contiguous ranges, two threads: each
/// range's results are kept apart (in the range's own variables, written back once: no cache
/// line shared by the threads in the loop) and combined in range order, so minima and counts
/// are those of one pass and gathered values come in one pass's order: the results are the
/// same, to the bit, as a single-threaded pass.
constexpr std::size_t ranges = 8;

/// body(begin, end, r) on the ranges r of [0, n).
template <typename F>
void for_ranges(std::size_t n, F&& body) {
  core::parallel_chunks(ranges, /*threads=*/2,
                        [&](std::size_t r) { body(n * r / ranges, n * (r + 1) / ranges, r); });
}

}  // namespace

std::string VesselContrastOptions::validate() const {
  std::ostringstream why;
  const std::string v = vesselness.validate();
  if (!v.empty()) why << "vesselness: " << v << "; ";
  if (!(grid_mm > 0.0) || !std::isfinite(grid_mm))
    why << "grid_mm must be > 0, got " << grid_mm << "; ";
  if (!(seed_vesselness > 0.0 && seed_vesselness <= 1.0))
    why << "seed_vesselness must lie in (0, 1], got " << seed_vesselness << "; ";
  if (!(noise_floor_k >= 0.0) || !std::isfinite(noise_floor_k))
    why << "noise_floor_k must be ≥ 0 and finite, got " << noise_floor_k << "; ";
  if (!(contrast_fraction > 0.0 && contrast_fraction < 1.0))
    why << "contrast_fraction must lie in (0, 1), got " << contrast_fraction << "; ";
  std::string text = why.str();
  if (!text.empty()) text.resize(text.size() - 2);
  return text;
}

VesselContrast vessel_contrast_threshold(const VolumeF& image, const VolumeF& filtered,
                                         const VesselContrastOptions& options) {
  const double noise_floor_k = options.noise_floor_k;
  VesselContrast out;
  const ImageGeometry& g = image.geometry;
  for (int a = 0; a < 3; ++a)
    out.factor[a] = std::max(1, int(std::floor(options.grid_mm / g.spacing[a] + 0.25)));
  const VolumeF mean = filters::downsample(filtered, out.factor);
  const VolumeF peak = filters::downsample(filtered, out.factor, /*maximum=*/true);
  out.vesselness = filters::frangi_vesselness(mean, options.vesselness);
  for (const float v : out.vesselness.data)
    out.vesselness_max = std::max(out.vesselness_max, double(v));
  if (!(out.vesselness_max > 0.0)) {
    out.empty_reason = "no tubular structure at any scale (vesselness 0 everywhere)";
    return out;
  }
  std::vector<float> values;
  for (std::size_t c = 0; c < out.vesselness.data.size(); ++c)
    if (out.vesselness.data[c] >= options.seed_vesselness * out.vesselness_max)
      values.push_back(peak.data[c]);
  out.seed_cells = std::int64_t(values.size());
  out.vessel_level = median_of(values);

  // Reference voxels: all finite ones, or those above the minimum in a masked image.
  float low = std::numeric_limits<float>::infinity();
  std::int64_t finite = 0, at_low = 0;
  {
    std::array<float, ranges> low_of;
    std::array<std::int64_t, ranges> finite_of{}, at_low_of{};
    low_of.fill(std::numeric_limits<float>::infinity());
    const std::size_t n = image.data.size();
    const float* data = image.data.data();
    for_ranges(n, [&](std::size_t b, std::size_t e, std::size_t r) {
      std::int64_t count = 0;
      float least = std::numeric_limits<float>::infinity();
      for (std::size_t v = b; v < e; ++v)
        if (std::isfinite(data[v])) {
          ++count;
          least = std::min(least, data[v]);
        }
      finite_of[r] = count;
      low_of[r] = least;
    });
    for (std::size_t r = 0; r < ranges; ++r) {
      finite += finite_of[r];
      low = std::min(low, low_of[r]);
    }
    for_ranges(n, [&](std::size_t b, std::size_t e, std::size_t r) {
      std::int64_t count = 0;
      for (std::size_t v = b; v < e; ++v) count += data[v] == low ? 1 : 0;
      at_low_of[r] = count;
    });
    for (const std::int64_t a : at_low_of) at_low += a;
  }
  out.masked_fraction = finite > 0 ? double(at_low) / double(finite) : 0.0;
  const bool masked = out.masked_fraction >= 0.5;
  const auto reference = [&](std::size_t v) {
    return std::isfinite(image.data[v]) && (!masked || image.data[v] > low);
  };

  // Background: the median of the cells around the vessels (2 to 4 cells from a seed, not
  // tubular themselves), else of all reference voxels.
  const ImageGeometry& c = out.vesselness.geometry;
  std::vector<std::uint8_t> near(out.vesselness.data.size(), 0);
  const float seed_level = float(options.seed_vesselness * out.vesselness_max);
  const float tubular_level = float(0.1 * out.vesselness_max);
  for (int k = 0; k < c.size[2]; ++k)
    for (int j = 0; j < c.size[1]; ++j)
      for (int i = 0; i < c.size[0]; ++i) {
        if (out.vesselness.at(i, j, k) < seed_level) continue;
        for (int dk = -4; dk <= 4; ++dk)
          for (int dj = -4; dj <= 4; ++dj)
            for (int di = -4; di <= 4; ++di) {
              const int ring = std::max({std::abs(di), std::abs(dj), std::abs(dk)});
              if (!c.contains_index(i + di, j + dj, k + dk)) continue;
              auto& n = near[std::size_t(c.linear_index(i + di, j + dj, k + dk))];
              n = std::max<std::uint8_t>(n, ring < 2 ? 2 : 1);  // 2: too close, 1: in the ring
            }
      }
  values.clear();
  for (std::size_t v = 0; v < near.size(); ++v)
    if (near[v] == 1 && out.vesselness.data[v] < tubular_level && std::isfinite(mean.data[v]))
      values.push_back(mean.data[v]);
  const bool local = values.size() >= 16;
  const auto filtered_at = [&](std::size_t v) { return filtered.data[v]; };
  double background = double(low);
  if (local) {
    background = median_of(values);
  } else if (const auto m = filters::median_where(image.data.size(), reference, filtered_at)) {
    background = m->value;
  }

  // Noise: 1.4826 × MAD of the differences between reference voxels `lag` apart (≈ 3 mm, beyond
  // the correlation of reconstructed noise and the pre-filter), over √2, in the cells around the
  // vessels when there are such (else everywhere): differences cancel the tissue levels and the
  // coil bias, which a global MAD would count as noise, and air or a masked-out region far from
  // the vessels does not dilute it.
  const auto around = [&](std::size_t v) {
    if (!local) return true;
    const auto ijk = Eigen::Vector3i(int(std::int64_t(v) % g.size[0]),
                                     int((std::int64_t(v) / g.size[0]) % g.size[1]),
                                     int(std::int64_t(v) / (std::int64_t(g.size[0]) * g.size[1])));
    return near[std::size_t(c.linear_index(ijk[0] / out.factor[0], ijk[1] / out.factor[1],
                                           ijk[2] / out.factor[2]))] == 1;
  };
  values.clear();
  for (int a = 0; a < 3; ++a) {
    const int lag = std::max(1, int(std::lround(3.0 / g.spacing[a])));
    if (g.size[a] <= lag) continue;
    const std::int64_t step = a == 0 ? 1 : a == 1 ? g.size[0] : std::int64_t(g.size[0]) * g.size[1];
    const int planes = (g.size[2] + 1) / 2;  // k = 0, 2, 4, …
    std::vector<std::vector<float>> part(ranges);
    for_ranges(std::size_t(planes), [&](std::size_t b, std::size_t e, std::size_t r) {
      for (int k = 2 * int(b); k < 2 * int(e); k += 2)
        for (int j = 0; j < g.size[1]; j += 2)
          for (int i = 0; i < g.size[0]; i += 2) {
            const int ijk[3] = {i, j, k};
            if (ijk[a] + lag >= g.size[a]) continue;
            const auto v = std::size_t(g.linear_index(i, j, k)),
                       w = std::size_t(std::int64_t(v) + lag * step);
            if (reference(v) && reference(w) && around(v) && around(w))
              part[r].push_back(filtered.data[v] - filtered.data[w]);
          }
    });
    for (const auto& p : part) values.insert(values.end(), p.begin(), p.end());
  }
  double sigma = 0.0;
  if (!values.empty()) {
    const double m = median_of(values);
    for (float& v : values) v = float(std::abs(double(v) - m));
    sigma = 1.4826 * median_of(values) / std::sqrt(2.0);
  }
  // A masked image whose non-minimum voxels are as bright as the vessels: the background was
  // suppressed, and what is left is the vessels themselves.
  double reference_median = background;
  if (masked) {
    const auto m = filters::median_where(image.data.size(), reference, filtered_at);
    reference_median = m ? double(m->value) : double(low);
  }
  const double low_filtered = [&] {
    std::array<float, ranges> m;
    m.fill(std::numeric_limits<float>::infinity());
    const float* data = filtered.data.data();
    for_ranges(filtered.data.size(), [&](std::size_t b, std::size_t e, std::size_t r) {
      float least = std::numeric_limits<float>::infinity();
      for (std::size_t v = b; v < e; ++v)
        if (std::isfinite(data[v])) least = std::min(least, data[v]);
      m[r] = least;
    });
    return double(*std::min_element(m.begin(), m.end()));
  }();
  if (masked && reference_median >= 0.5 * (low_filtered + out.vessel_level)) {
    out.background_suppressed = true;
    background = std::min(double(low), low_filtered);
    sigma = 0.0;
  }
  out.background_level = background;
  out.noise_sigma = sigma;
  const double contrast = out.vessel_level - background;
  const double floor = background + noise_floor_k * sigma;
  std::ostringstream why;
  if (!(contrast > 0.0)) {
    why << "no vessel contrast: the most tubular structures (level " << out.vessel_level
        << ") are not brighter than the background (" << background << ")";
    out.empty_reason = why.str();
    return out;
  }
  if (floor >= out.vessel_level) {
    why << "no vessels above the noise: the most tubular structures (level " << out.vessel_level
        << ") are within " << noise_floor_k << " σ̂ of the background (" << background << " ± "
        << sigma << ")";
    out.empty_reason = why.str();
    return out;
  }
  out.threshold = background + options.contrast_fraction * contrast;
  out.rule = "vessel contrast";
  if (floor > out.threshold) {
    out.threshold = floor;
    out.rule = "noise floor";
    why << "weak vessel contrast: the vessels (level " << out.vessel_level << ") stand only "
        << (sigma > 0.0 ? contrast / sigma : 0.0) << " σ̂ above the background (" << background
        << " ± " << sigma << "); the threshold was raised to the noise floor " << floor;
    out.warning = why.str();
  }
  return out;
}

}  // namespace brainshift::imaging
