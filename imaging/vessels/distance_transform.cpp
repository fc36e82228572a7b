#include "imaging/vessels/distance_transform.hpp"

#include <cmath>
#include <limits>
#include <vector>

namespace brainshift::imaging {
namespace {

/// Squared-distance transform of one line f[0..n) (f = 0 on sites, +inf elsewhere), with sample
/// spacing h, and virtual sites (0) just outside both ends. Felzenszwalb–Huttenlocher lower
/// envelope; `v`, `z` are scratch of size ≥ n + 3.
void line_transform(const float* f, float* d, int n, double h, std::vector<int>& v,
                    std::vector<double>& z, std::vector<double>& g) {
  // Extended line: index 0 and n + 1 are the virtual background sites.
  const int m = n + 2;
  g[0] = 0.0;
  g[std::size_t(m - 1)] = 0.0;
  for (int q = 0; q < n; ++q) g[std::size_t(q + 1)] = f[q];
  const double h2 = h * h;
  constexpr double inf = std::numeric_limits<double>::infinity();
  int k = 0;
  v[0] = 0;
  z[0] = -inf;
  z[1] = inf;
  for (int q = 1; q < m; ++q) {
    if (!std::isfinite(g[std::size_t(q)])) continue;
    double s = 0.0;
    while (true) {
      const int p = v[std::size_t(k)];
      // Intersection of the parabolas rooted at q and p (in index units).
      s = ((g[std::size_t(q)] + h2 * q * q) - (g[std::size_t(p)] + h2 * p * p)) /
          (2.0 * h2 * (q - p));
      if (s <= z[std::size_t(k)] && k > 0) {
        --k;
        continue;
      }
      break;
    }
    ++k;
    v[std::size_t(k)] = q;
    z[std::size_t(k)] = s;
    z[std::size_t(k + 1)] = inf;
  }
  k = 0;
  for (int q = 1; q <= n; ++q) {
    while (z[std::size_t(k + 1)] < q) ++k;
    const int p = v[std::size_t(k)];
    d[q - 1] = static_cast<float>(h2 * (q - p) * (q - p) + g[std::size_t(p)]);
  }
}

}  // namespace

VolumeF distance_to_background(const Volume<std::uint8_t>& mask) {
  BS_VERIFY(mask.components == 1,
            "distance transform needs a one-component mask, got " << mask.components);
  const ImageGeometry& g = mask.geometry;
  const Eigen::Vector3i n = g.size;
  VolumeF out(g, 1);
  constexpr float inf = std::numeric_limits<float>::infinity();
  for (std::size_t v = 0; v < mask.data.size(); ++v) out.data[v] = mask.data[v] != 0 ? inf : 0.0f;

  const auto longest = static_cast<std::size_t>(n.maxCoeff());
  std::vector<int> vs(longest + 3, 0);
  std::vector<double> zs(longest + 4, 0.0), gs(longest + 3, 0.0);
  std::vector<float> in(longest, 0.0f), res(longest, 0.0f);
  const std::int64_t stride[3] = {1, n[0], std::int64_t(n[0]) * n[1]};
  for (int axis = 0; axis < 3; ++axis) {
    const int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
    const int len = n[axis];
    for (int u = 0; u < n[a2]; ++u)
      for (int w = 0; w < n[a1]; ++w) {
        const std::int64_t base = std::int64_t(u) * stride[a2] + std::int64_t(w) * stride[a1];
        bool any = false;
        for (int q = 0; q < len; ++q) {
          in[std::size_t(q)] = out.data[std::size_t(base + q * stride[axis])];
          any = any || in[std::size_t(q)] != 0.0f;
        }
        if (!any) continue;  // all background: stays 0
        line_transform(in.data(), res.data(), len, g.spacing[axis], vs, zs, gs);
        for (int q = 0; q < len; ++q)
          out.data[std::size_t(base + q * stride[axis])] = res[std::size_t(q)];
      }
  }
  for (float& d : out.data) d = std::sqrt(d);
  return out;
}

}  // namespace brainshift::imaging
