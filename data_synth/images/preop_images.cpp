#include "data_synth/images/preop_images.hpp"

#include "core/error.hpp"
#include "data_synth/images/tube_raster.hpp"

#include <algorithm>
#include <cmath>
#include <random>
#include <sstream>

namespace brainshift::data_synth {

std::string MriOptions::validate() const {
  std::ostringstream s;
  if (!(bias_amplitude >= 0.0 && bias_amplitude < 1.0))
    s << "bias_amplitude must lie in [0, 1), got " << bias_amplitude;
  else if (!(noise_sigma >= 0.0))
    s << "noise_sigma must be >= 0, got " << noise_sigma;
  else if (!(cortex_thickness >= 0.0))
    s << "cortex_thickness must be >= 0 mm";
  return s.str();
}

std::string MraOptions::validate() const {
  std::ostringstream s;
  if (!(noise_sigma >= 0.0))
    s << "noise_sigma must be >= 0, got " << noise_sigma;
  else if (!(large_radius > 0.0))
    s << "large_radius must be > 0 mm, got " << large_radius;
  return s.str();
}

namespace {

/// Voxels of the brain (label ≠ 0) within `thickness` mm of a background voxel (city-block
/// erosion in voxel steps).
std::vector<std::uint8_t> outer_rim(const imaging::LabelVolume& labels, double thickness) {
  const imaging::ImageGeometry& g = labels.geometry;
  std::vector<std::uint8_t> rim(labels.data.size(), 0);
  std::vector<std::uint8_t> front(labels.data.size(), 0);
  for (std::size_t v = 0; v < labels.data.size(); ++v) front[v] = labels.data[v] == 0;
  const int passes = int(std::lround(thickness / g.spacing.minCoeff()));
  for (int pass = 0; pass < passes; ++pass) {
    std::vector<std::uint8_t> next = front;
    for (int k = 1; k + 1 < g.size[2]; ++k)
      for (int j = 1; j + 1 < g.size[1]; ++j)
        for (int i = 1; i + 1 < g.size[0]; ++i) {
          const auto v = std::size_t(g.linear_index(i, j, k));
          if (front[v] || labels.data[v] == 0) continue;
          const std::int64_t n[6] = {g.linear_index(i - 1, j, k), g.linear_index(i + 1, j, k),
                                     g.linear_index(i, j - 1, k), g.linear_index(i, j + 1, k),
                                     g.linear_index(i, j, k - 1), g.linear_index(i, j, k + 1)};
          for (const auto m : n)
            if (front[std::size_t(m)]) {
              next[v] = 1;
              rim[v] = 1;
              break;
            }
        }
    front.swap(next);
  }
  return rim;
}

}  // namespace

imaging::VolumeF make_mri(const imaging::LabelVolume& labels, const MriOptions& options) {
  const std::string bad = options.validate();
  BS_VERIFY(bad.empty(), "invalid MRI options: " << bad);
  const imaging::ImageGeometry& g = labels.geometry;
  imaging::VolumeF mri(g, 1, 0.0F);
  const std::vector<std::uint8_t> rim = outer_rim(labels, options.cortex_thickness);
  std::mt19937 rng(options.seed);
  std::uniform_real_distribution<double> coef(-1.0, 1.0);
  // Bias: 1 + a·b(ξ), b a random quadratic in the normalised index ξ ∈ [−1, 1]³ scaled to |b| ≤ 1.
  Eigen::Matrix<double, 10, 1> c;
  for (int i = 0; i < 10; ++i) c[i] = coef(rng);
  c /= c.cwiseAbs().sum();
  const Vector3d half = (g.size.cast<double>() - Vector3d::Ones()) / 2.0;
  for (int k = 0; k < g.size[2]; ++k)
    for (int j = 0; j < g.size[1]; ++j)
      for (int i = 0; i < g.size[0]; ++i) {
        const auto v = std::size_t(g.linear_index(i, j, k));
        double value = options.background;
        switch (labels.data[v]) {
          case imaging::BACKGROUND:
            break;
          case imaging::BRAIN:
            value = rim[v] ? options.cortex : options.brain;
            break;
          case imaging::TUMOUR:
            value = options.tumour;
            break;
          case imaging::VENTRICLES:
            value = options.ventricles;
            break;
          default:
            BS_THROW("label " << int(labels.data[v]) << " at voxel (" << i << ", " << j << ", " << k
                              << ") is not 0, 1, 2 or 3");
        }
        const Vector3d x = (Vector3d(i, j, k) - half).cwiseQuotient(half.cwiseMax(1.0));
        const double b = c[0] + c[1] * x[0] + c[2] * x[1] + c[3] * x[2] + c[4] * x[0] * x[0] +
                         c[5] * x[1] * x[1] + c[6] * x[2] * x[2] + c[7] * x[0] * x[1] +
                         c[8] * x[1] * x[2] + c[9] * x[0] * x[2];
        mri.data[v] = float(value * (1.0 + options.bias_amplitude * b));
      }
  add_gaussian_noise(mri, options.noise_sigma, rng);
  for (float& v : mri.data) v = std::abs(v);  // magnitude image (Rician-like floor)
  return mri;
}

imaging::VolumeF make_mra(const imaging::LabelVolume& labels, const VesselTree& tree,
                          const MraOptions& options) {
  const std::string bad = options.validate();
  BS_VERIFY(bad.empty(), "invalid MRA options: " << bad);
  imaging::VolumeF vessels(labels.geometry, 1, 0.0F);
  const double r0 =
      tree.radius.empty() ? 0.5 : *std::min_element(tree.radius.begin(), tree.radius.end());
  draw_tubes(vessels, tube_segments(tree), [&](double r) {
    const double t = std::clamp((r - r0) / std::max(options.large_radius - r0, 1e-6), 0.0, 1.0);
    return options.vessel_small + t * (options.vessel_large - options.vessel_small);
  });
  imaging::VolumeF mra(labels.geometry, 1, 0.0F);
  for (std::size_t v = 0; v < mra.data.size(); ++v) {
    const double tissue = labels.data[v] == 0 ? options.background : options.tissue;
    mra.data[v] = std::max(float(tissue), vessels.data[v]);
  }
  std::mt19937 rng(options.seed);
  add_gaussian_noise(mra, options.noise_sigma, rng);
  for (float& v : mra.data) v = std::abs(v);
  return mra;
}

}  // namespace brainshift::data_synth
