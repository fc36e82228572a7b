#include "imaging/filters/trilinear.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>

namespace brainshift::imaging::filters {

bool on_sampling_grid(const ImageGeometry& geometry, const Vector3d& ijk) {
  for (int a = 0; a < 3; ++a)
    if (!(ijk[a] >= -0.5 && ijk[a] <= geometry.size[a] - 0.5)) return false;  // also NaN
  return true;
}

float sample_trilinear(const VolumeF& image, const Vector3d& ijk, MissingData missing,
                       int component) {
  constexpr float nan = std::numeric_limits<float>::quiet_NaN();
  const auto& n = image.geometry.size;
  if (!on_sampling_grid(image.geometry, ijk)) {
    if (missing == MissingData::ZERO) return 0.0F;
    if (missing != MissingData::CLAMP || !ijk.allFinite()) return nan;
  }
  // The 2×2×2 block: its first corner and the fractions, the index clamped onto the centres.
  std::array<int, 3> i0{};
  std::array<double, 3> f{};
  for (int d = 0; d < 3; ++d) {
    const double c = std::clamp(ijk[d], 0.0, double(n[d] - 1));
    const int lo = std::min(int(c), std::max(n[d] - 2, 0));
    i0[std::size_t(d)] = lo;
    f[std::size_t(d)] = c - lo;
  }
  const std::int64_t sx = 1, sy = n[0], sz = std::int64_t(n[0]) * n[1];
  const std::int64_t dx = n[0] > 1 ? sx : 0, dy = n[1] > 1 ? sy : 0, dz = n[2] > 1 ? sz : 0;
  const float* p =
      image.data.data() + (i0[2] * sz + i0[1] * sy + i0[0]) * image.components + component;
  const auto raw = [&](std::int64_t off) { return double(p[off * image.components]); };

  if (missing == MissingData::RENORMALISE) {
    double sum = 0.0;
    double weight = 0.0;
    for (int corner = 0; corner < 8; ++corner) {
      double w = 1.0;
      std::int64_t off = 0;
      const std::int64_t step[3] = {dx, dy, dz};
      for (int a = 0; a < 3; ++a) {
        const int bit = (corner >> a) & 1;
        w *= bit ? f[std::size_t(a)] : 1.0 - f[std::size_t(a)];
        off += bit * step[a];
      }
      if (w <= 0.0) continue;
      const double v = raw(off);
      if (!std::isfinite(v)) continue;
      sum += w * v;
      weight += w;
    }
    return weight >= 0.5 ? float(sum / weight) : nan;
  }
  const bool zero = missing == MissingData::ZERO;
  const auto at = [&](std::int64_t off) {
    const double v = raw(off);
    return zero && !std::isfinite(v) ? 0.0 : v;
  };
  const double wx = f[0], wy = f[1], wz = f[2];
  const double c00 = (1 - wx) * at(0) + wx * at(dx);
  const double c10 = (1 - wx) * at(dy) + wx * at(dy + dx);
  const double c01 = (1 - wx) * at(dz) + wx * at(dz + dx);
  const double c11 = (1 - wx) * at(dz + dy) + wx * at(dz + dy + dx);
  const double c0 = (1 - wy) * c00 + wy * c10;
  const double c1 = (1 - wy) * c01 + wy * c11;
  return float((1 - wz) * c0 + wz * c1);
}

}  // namespace brainshift::imaging::filters
