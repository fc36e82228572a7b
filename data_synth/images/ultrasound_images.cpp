#include "data_synth/images/ultrasound_images.hpp"

#include "core/error.hpp"
#include "data_synth/images/tet_raster.hpp"
#include "data_synth/images/tube_raster.hpp"

#include <algorithm>
#include <cmath>
#include <random>
#include <sstream>

namespace brainshift::data_synth {

std::string DopplerOptions::validate() const {
  std::ostringstream s;
  if (!(dropout >= 0.0 && dropout <= 0.4))
    s << "dropout must lie in [0, 0.4], got " << dropout;
  else if (!(dropout_run >= 1.0))
    s << "dropout_run must be >= 1, got " << dropout_run;
  else if (!(thickening_scale > 0.0 && thickening_add >= 0.0 && blur_sigma >= 0.0))
    s << "thickening_scale > 0, thickening_add >= 0 and blur_sigma >= 0 expected";
  else if (!(speckle_shape > 0.0) || spurious_blobs < 0 || !(clutter_sigma >= 0.0))
    s << "speckle_shape > 0, spurious_blobs >= 0, clutter_sigma >= 0 expected";
  return s.str();
}

std::string BmodeOptions::validate() const {
  std::ostringstream s;
  if (!(attenuation >= 0.0 && band_thickness >= 0.0 && speckle_blur >= 0.0 && contact_gap >= 0.0))
    s << "attenuation, band_thickness, contact_gap and speckle_blur must be >= 0";
  return s.str();
}

imaging::LabelVolume deformed_labels(const TruthField& truth, const PhantomGeometry& geometry,
                                     const imaging::ImageGeometry& grid, bool resected) {
  return deformed_labels(
      truth, [&](const Vector3d& X) { return geometry.label_at(X); }, grid, resected);
}

imaging::LabelVolume deformed_labels(const TruthField& truth,
                                     const std::function<imaging::Label(const Vector3d&)>& label_at,
                                     const imaging::ImageGeometry& grid, bool resected) {
  imaging::LabelVolume labels(grid, 1, imaging::BACKGROUND);
  const MatrixX3d& rest = truth.rest_nodes();
  const MatrixX4i& tets = truth.tets();
  rasterize_tets(truth.deformed_nodes(), tets, grid,
                 [&](std::int64_t v, index_t t, const Vector4d& w) {
                   Vector3d X = Vector3d::Zero();
                   for (int a = 0; a < 4; ++a) X += w[a] * rest.row(tets(t, a)).transpose();
                   imaging::Label l = label_at(X);
                   if (l == imaging::BACKGROUND)
                     l = imaging::BRAIN;  // truth-mesh slivers outside the ellipsoid
                   if (resected && l == imaging::TUMOUR) l = imaging::BACKGROUND;
                   labels.data[std::size_t(v)] = l;
                 });
  return labels;
}

namespace {

/// Zeroes everything outside the field of view.
void mask_field_of_view(imaging::VolumeF& image, const Probe& probe) {
  const imaging::ImageGeometry& g = image.geometry;
  for (int k = 0; k < g.size[2]; ++k)
    for (int j = 0; j < g.size[1]; ++j)
      for (int i = 0; i < g.size[0]; ++i)
        if (!probe.in_field_of_view(g.index_to_world(Vector3d(i, j, k)))) image.at(i, j, k) = 0.0F;
}

/// The tree's segments with runs dropped (a two-state Markov chain over the edges in growth
/// order, so that missing parts are contiguous pieces of branches).
VesselTree with_dropout(const VesselTree& tree, const DopplerOptions& o, std::mt19937& rng) {
  VesselTree kept = tree;
  kept.edges.clear();
  const double p_end = 1.0 / o.dropout_run;
  const double p_start = o.dropout >= 1.0 ? 1.0 : o.dropout * p_end / (1.0 - o.dropout);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  bool dropping = false;
  for (const auto& e : tree.edges) {
    dropping = dropping ? u(rng) >= p_end : u(rng) < p_start;
    if (!dropping) kept.edges.push_back(e);
  }
  return kept;
}

}  // namespace

imaging::VolumeF make_doppler(const Probe& probe, const VesselTree& deformed_tree,
                              const imaging::LabelVolume& labels, const DopplerOptions& options) {
  const std::string bad = options.validate();
  BS_VERIFY(bad.empty(), "invalid Doppler options: " << bad);
  const imaging::ImageGeometry grid = probe.grid();
  BS_VERIFY(labels.geometry.size == grid.size, "Doppler labels must be on the probe grid");
  std::mt19937 rng(options.seed);
  imaging::VolumeF image(grid, 1, 0.0F);
  const VesselTree kept = with_dropout(deformed_tree, options, rng);
  draw_tubes(image, tube_segments(kept, options.thickening_scale, options.thickening_add),
             [](double) { return 1.0; });
  // Spurious flow blobs inside the deformed brain and the field of view.
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int b = 0, tries = 0; b < options.spurious_blobs && tries < 1000; ++tries) {
    const Vector3d ijk(u(rng) * (grid.size[0] - 1), u(rng) * (grid.size[1] - 1),
                       u(rng) * (grid.size[2] - 1));
    const Vector3d c = grid.index_to_world(ijk);
    const Eigen::Vector3i n = ijk.array().round().cast<int>();
    if (!probe.in_field_of_view(c) || labels.at(n[0], n[1], n[2]) == imaging::BACKGROUND) continue;
    ++b;
    const double sigma = 0.8 + 1.2 * u(rng), amplitude = 0.4 + 0.5 * u(rng);
    const int reach = int(std::ceil(3.0 * sigma / grid.spacing[0]));
    for (int k = std::max(0, n[2] - reach); k <= std::min(grid.size[2] - 1, n[2] + reach); ++k)
      for (int j = std::max(0, n[1] - reach); j <= std::min(grid.size[1] - 1, n[1] + reach); ++j)
        for (int i = std::max(0, n[0] - reach); i <= std::min(grid.size[0] - 1, n[0] + reach);
             ++i) {
          const double d2 = (grid.index_to_world(Vector3d(i, j, k)) - c).squaredNorm();
          float& v = image.at(i, j, k);
          v = std::max(v, float(amplitude * std::exp(-0.5 * d2 / (sigma * sigma))));
        }
  }
  gaussian_blur(image, options.blur_sigma);
  std::gamma_distribution<double> speckle(options.speckle_shape, 1.0 / options.speckle_shape);
  std::normal_distribution<double> clutter(0.0, options.clutter_sigma);
  for (float& v : image.data)
    v = float(std::clamp(255.0 * v * speckle(rng) + std::abs(clutter(rng)), 0.0, 255.0));
  mask_field_of_view(image, probe);
  return image;
}

imaging::VolumeF make_bmode(const Probe& probe, const imaging::LabelVolume& labels,
                            const BmodeOptions& options) {
  const std::string bad = options.validate();
  BS_VERIFY(bad.empty(), "invalid B-mode options: " << bad);
  const imaging::ImageGeometry grid = probe.grid();
  BS_VERIFY(labels.geometry.size == grid.size, "B-mode labels must be on the probe grid");
  std::mt19937 rng(options.seed);
  std::normal_distribution<double> n01(0.0, 1.0);
  // Rayleigh speckle, spatially correlated by a small blur, normalised to mean ≈ 1.
  imaging::VolumeF speckle(grid, 1, 0.0F);
  for (float& v : speckle.data) v = float(std::hypot(n01(rng), n01(rng)));
  gaussian_blur(speckle, options.speckle_blur);
  double mean = 0.0;
  for (const float v : speckle.data) mean += v;
  mean /= double(speckle.data.size());
  imaging::VolumeF image(grid, 1, 0.0F);
  // The grid's k axis is the beam: along each beam line (i, j), the first tissue voxel is the
  // brain surface; within `contact_gap` of the face it carries the interface echo, a band
  // `band_thickness` deep below it.
  for (int j = 0; j < grid.size[1]; ++j)
    for (int i = 0; i < grid.size[0]; ++i) {
      double surface = -1.0;  // depth of the brain surface on this beam line, < 0: none yet
      for (int k = 0; k < grid.size[2]; ++k) {
        const Vector3d p = grid.index_to_world(Vector3d(i, j, k));
        const double depth = probe.depth_of(p);
        double echo = options.fluid;
        switch (labels.at(i, j, k)) {
          case imaging::BRAIN:
            echo = options.brain;
            break;
          case imaging::TUMOUR:
            echo = options.tumour;
            break;
          case imaging::VENTRICLES:
            echo = options.ventricles;
            break;
          default:
            break;
        }
        if (surface < 0.0 && labels.at(i, j, k) != imaging::BACKGROUND && probe.in_field_of_view(p))
          surface = depth;
        double value = echo * speckle.at(i, j, k) / mean * std::exp(-options.attenuation * depth);
        if (surface >= 0.0 && surface <= options.contact_gap &&
            depth - surface < options.band_thickness && labels.at(i, j, k) != imaging::BACKGROUND)
          value = std::max(value, options.band * (0.9 + 0.1 * speckle.at(i, j, k) / mean));
        image.at(i, j, k) = float(std::clamp(255.0 * value, 0.0, 255.0));
      }
    }
  mask_field_of_view(image, probe);
  return image;
}

}  // namespace brainshift::data_synth
