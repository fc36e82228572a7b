#include "imaging/filters/gaussian.hpp"

#include "imaging/filters/parallel.hpp"
#include "imaging/filters/separable.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace brainshift::imaging::filters {
std::vector<double> gaussian_kernel(double s, int order) {
  BS_VERIFY(order >= 0 && order <= 2, "Gaussian kernel order must be 0, 1 or 2, got " << order);
  if (!(s >= 0.05)) return {};
  const int r = std::max(1, int(std::ceil(3.0 * s)));
  std::vector<double> g(std::size_t(2 * r + 1));
  double sum = 0.0;
  for (int t = -r; t <= r; ++t) sum += g[std::size_t(t + r)] = std::exp(-0.5 * t * t / (s * s));
  for (double& w : g) w /= sum;
  if (order == 0) return g;
  std::vector<double> k(g.size());
  for (int t = -r; t <= r; ++t) {
    const double w = g[std::size_t(t + r)];
    k[std::size_t(t + r)] =
        order == 1 ? -t / (s * s) * w : (double(t) * t / (s * s * s * s) - 1.0 / (s * s)) * w;
  }
  // Exact moments on the sampled, truncated kernel: Σ t·k = −1 (order 1); Σ k = 0 and
  // Σ t²·k = 2 (order 2), so ramps and parabolas are differentiated exactly.
  if (order == 1) {
    double m1 = 0.0;
    for (int t = -r; t <= r; ++t) m1 += t * k[std::size_t(t + r)];
    for (double& w : k) w /= -m1;
  } else {
    double m0 = 0.0;
    for (const double w : k) m0 += w;
    for (int t = -r; t <= r; ++t) k[std::size_t(t + r)] -= m0 * g[std::size_t(t + r)];
    double m2 = 0.0;
    for (int t = -r; t <= r; ++t) m2 += double(t) * t * k[std::size_t(t + r)];
    for (double& w : k) w *= 2.0 / m2;
  }
  return k;
}

VolumeF gaussian_filter(const VolumeF& image, double sigma_mm, const std::array<int, 3>& order) {
  BS_VERIFY(image.components == 1,
            "Gaussian filter needs a one-component volume, got " << image.components);
  BS_VERIFY(sigma_mm >= 0.0 && std::isfinite(sigma_mm),
            "Gaussian filter σ must be ≥ 0 and finite, got " << sigma_mm);
  for (const int o : order)
    BS_VERIFY(o >= 0 && o <= 2, "Gaussian derivative order must be 0, 1 or 2, got " << o);
  BS_VERIFY(image.data.size() == std::size_t(image.geometry.voxel_count()),
            "Gaussian filter: volume holds " << image.data.size() << " values for "
                                             << image.geometry.voxel_count() << " voxels");
  VolumeF out = image;
  // Non-finite voxels count as 0 in the passes (restored below); planes on threads.
  const std::size_t plane =
      std::size_t(image.geometry.size[0]) * std::size_t(image.geometry.size[1]);
  std::vector<char> non_finite_in(std::size_t(image.geometry.size[2]), 0);
  parallel_for(image.geometry.size[2], [&](int k0, int k1) {
    for (int k = k0; k < k1; ++k)
      for (std::size_t v = plane * std::size_t(k); v < plane * std::size_t(k + 1); ++v)
        if (!std::isfinite(out.data[v])) {
          out.data[v] = 0.0F;
          non_finite_in[std::size_t(k)] = 1;
        }
  });
  const bool any_non_finite =
      std::find(non_finite_in.begin(), non_finite_in.end(), 1) != non_finite_in.end();
  const Eigen::Vector3i& n = image.geometry.size;
  for (int axis = 0; axis < 3; ++axis) {
    const double s = sigma_mm / image.geometry.spacing[axis];
    std::vector<double> kernel =
        n[axis] >= 2 ? gaussian_kernel(s, order[std::size_t(axis)]) : std::vector<double>{};
    if (kernel.empty() && order[std::size_t(axis)] > 0) {
      // Narrow or absent smoothing: central differences (zero on a one-voxel axis).
      kernel = order[std::size_t(axis)] == 1 ? std::vector<double>{0.5, 0.0, -0.5}
                                             : std::vector<double>{1.0, -2.0, 1.0};
      if (n[axis] < 2) kernel = {0.0, 0.0, 0.0};
    }
    if (kernel.empty()) continue;
    if (order[std::size_t(axis)] == 1)
      std::reverse(kernel.begin(), kernel.end());  // correlation → convolution
    for (double& w : kernel)
      w /= (order[std::size_t(axis)] == 0
                ? 1.0
                : std::pow(image.geometry.spacing[axis], order[std::size_t(axis)]));
    // Smoothing renormalises at the faces; derivatives repeat the face voxel (Neumann).
    filter_axis(out.data, n, axis, kernel,
                order[std::size_t(axis)] == 0 ? MissingData::RENORMALISE : MissingData::CLAMP);
  }
  if (any_non_finite)
    for (std::size_t v = 0; v < out.data.size(); ++v)
      if (!std::isfinite(image.data[v])) out.data[v] = image.data[v];
  return out;
}

double gaussian_noise_gain(const ImageGeometry& g, double sigma_mm) {
  double gain = 1.0;
  if (!(sigma_mm > 0.0)) return gain;
  for (int axis = 0; axis < 3; ++axis) {
    if (g.size[axis] < 2) continue;
    const std::vector<double> k = gaussian_kernel(sigma_mm / g.spacing[axis], 0);
    double sum2 = 0.0;
    for (const double w : k) sum2 += w * w;
    if (!k.empty()) gain *= std::sqrt(sum2);
  }
  return gain;
}

VolumeF downsample(const VolumeF& image, const Eigen::Vector3i& factor, bool maximum) {
  BS_VERIFY(image.components == 1,
            "downsampling needs a one-component volume, got " << image.components);
  BS_VERIFY(factor.minCoeff() >= 1, "downsampling factors must be ≥ 1, got " << factor.transpose());
  const ImageGeometry& g = image.geometry;
  ImageGeometry c = g;
  for (int a = 0; a < 3; ++a) {
    c.size[a] = (g.size[a] + factor[a] - 1) / factor[a];
    c.spacing[a] = g.spacing[a] * factor[a];
  }
  // Block (0,0,0) covers input voxels 0 … f−1: its centre is at index (f − 1)/2.
  c.origin = g.index_to_world(0.5 * (factor.cast<double>() - Vector3d::Ones()));
  VolumeF out(c, 1, 0.0F);
  std::vector<float> count(out.data.size(), 0.0F);
  // Output planes in parallel: each output voxel is accumulated by one thread, over its input
  // voxels in the same (k, j, i) order as one pass, so the result does not depend on the split.
  parallel_for(c.size[2], [&](int kc0, int kc1) {
    for (int k = kc0 * factor[2]; k < std::min(g.size[2], kc1 * factor[2]); ++k)
      for (int j = 0; j < g.size[1]; ++j) {
        const std::int64_t row = c.linear_index(0, j / factor[1], k / factor[2]);
        const float* in = &image.data[std::size_t(g.linear_index(0, j, k))];
        // Output voxel by output voxel, its inputs of this row in order, held in registers: the
        // same additions in the same order as one voxel at a time (the same bits), without a
        // division per input voxel.
        for (int io = 0; io < c.size[0]; ++io) {
          const std::size_t o = std::size_t(row + io);
          float acc = out.data[o], n = count[o];
          const int i1 = std::min(g.size[0], (io + 1) * factor[0]);
          for (int i = io * factor[0]; i < i1; ++i) {
            const float v = in[i];
            if (!std::isfinite(v)) continue;
            if (maximum)
              acc = n == 0.0F ? v : std::max(acc, v);
            else
              acc += v;
            n += 1.0F;
          }
          out.data[o] = acc;
          count[o] = n;
        }
      }
    if (!maximum) {
      const std::size_t plane = std::size_t(c.size[0]) * std::size_t(c.size[1]);
      for (std::size_t o = plane * std::size_t(kc0); o < plane * std::size_t(kc1); ++o)
        if (count[o] > 0.0F) out.data[o] /= count[o];
    }
  });
  return out;
}

}  // namespace brainshift::imaging::filters
