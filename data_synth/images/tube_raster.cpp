#include "data_synth/images/tube_raster.hpp"

#include "core/error.hpp"
#include "imaging/filters/gaussian.hpp"
#include "imaging/filters/separable.hpp"

#include <algorithm>
#include <cmath>

namespace brainshift::data_synth {

std::vector<TubeSegment> tube_segments(const VesselTree& tree, double scale, double add) {
  std::vector<TubeSegment> out;
  out.reserve(tree.edges.size());
  for (const auto& e : tree.edges) {
    const auto a = std::size_t(e[0]), b = std::size_t(e[1]);
    out.push_back({tree.points[a], tree.points[b], tree.radius[a] * scale + add,
                   tree.radius[b] * scale + add});
  }
  return out;
}

void draw_tubes(imaging::VolumeF& volume, const std::vector<TubeSegment>& segments,
                const std::function<double(double radius_mm)>& peak) {
  BS_VERIFY(volume.components == 1, "draw_tubes needs a one-component volume");
  const imaging::ImageGeometry& g = volume.geometry;
  const double h = g.spacing.mean();
  for (const TubeSegment& s : segments) {
    const double reach = std::max(s.radius_a, s.radius_b) + h;
    Vector3d lo = Vector3d::Constant(1e300), hi = Vector3d::Constant(-1e300);
    for (const Vector3d& p : {s.a, s.b})
      for (int corner = 0; corner < 8; ++corner) {
        const Vector3d off((corner & 1) ? reach : -reach, (corner & 2) ? reach : -reach,
                           (corner & 4) ? reach : -reach);
        const Vector3d ijk = g.world_to_index(p + off);
        lo = lo.cwiseMin(ijk);
        hi = hi.cwiseMax(ijk);
      }
    Eigen::Vector3i a, b;
    for (int d = 0; d < 3; ++d) {
      a[d] = std::max(0, int(std::ceil(lo[d])));
      b[d] = std::min(g.size[d] - 1, int(std::floor(hi[d])));
    }
    const Vector3d ab = s.b - s.a;
    const double len2 = ab.squaredNorm();
    for (int k = a[2]; k <= b[2]; ++k)
      for (int j = a[1]; j <= b[1]; ++j)
        for (int i = a[0]; i <= b[0]; ++i) {
          const Vector3d p = g.index_to_world(Vector3d(i, j, k));
          const double t = len2 > 0.0 ? std::clamp((p - s.a).dot(ab) / len2, 0.0, 1.0) : 0.0;
          const double d = (p - (s.a + t * ab)).norm();
          const double r = s.radius_a + t * (s.radius_b - s.radius_a);
          const double c = std::clamp(0.5 + (r - d) / h, 0.0, 1.0);
          if (c <= 0.0) continue;
          float& v = volume.at(i, j, k);
          v = std::max(v, float(c * peak(r)));
        }
  }
}

void gaussian_blur(imaging::VolumeF& volume, double sigma_mm) {
  BS_VERIFY(volume.components == 1, "gaussian_blur needs a one-component volume");
  if (!(sigma_mm > 0.0)) return;
  for (int axis = 0; axis < 3; ++axis) {
    const std::vector<double> kernel =
        imaging::filters::gaussian_kernel(sigma_mm / volume.geometry.spacing[axis], 0);
    if (kernel.empty()) continue;  // below 1/20 voxel: the identity
    imaging::filters::filter_axis(volume.data, volume.geometry.size, axis, kernel,
                                  imaging::filters::MissingData::CLAMP);
  }
}

void add_gaussian_noise(imaging::VolumeF& volume, double sigma, std::mt19937& rng) {
  if (!(sigma > 0.0)) return;
  std::normal_distribution<float> noise(0.0F, float(sigma));
  for (float& v : volume.data) v += noise(rng);
}

}  // namespace brainshift::data_synth
