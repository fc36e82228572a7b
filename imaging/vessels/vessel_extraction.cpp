#include "imaging/vessels/vessel_extraction.hpp"

#include "core/logger.hpp"
#include "imaging/filters/gaussian.hpp"
#include "imaging/filters/parallel.hpp"
#include "imaging/vessels/distance_transform.hpp"
#include "imaging/vessels/thinning.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <optional>
#include <sstream>
#include <vector>

namespace brainshift::imaging {
namespace {

using Mask = Volume<std::uint8_t>;

/// The sub-grid [lo, hi] (inclusive voxel indices) of `g`.
ImageGeometry crop_geometry(const ImageGeometry& g, const Eigen::Vector3i& lo,
                            const Eigen::Vector3i& hi) {
  ImageGeometry c = g;
  c.size = hi - lo + Eigen::Vector3i::Ones();
  c.origin = g.index_to_world(lo.cast<double>());
  return c;
}

/// Labels 26-connected components of `mask` (in place: 0 background, k ≥ 1 the label of
/// component k − 1); returns their voxel counts.
std::vector<std::int64_t> label_components(const Mask& mask, std::vector<int>& label) {
  const Eigen::Vector3i n = mask.geometry.size;
  label.assign(mask.data.size(), 0);
  std::vector<std::int64_t> sizes;
  std::vector<std::int64_t> stack;
  for (std::int64_t seed = 0; seed < std::int64_t(mask.data.size()); ++seed) {
    if (mask.data[std::size_t(seed)] == 0 || label[std::size_t(seed)] != 0) continue;
    const int id = int(sizes.size()) + 1;
    std::int64_t count = 0;
    label[std::size_t(seed)] = id;
    stack.push_back(seed);
    while (!stack.empty()) {
      const std::int64_t v = stack.back();
      stack.pop_back();
      ++count;
      const int i = int(v % n[0]), j = int((v / n[0]) % n[1]),
                k = int(v / (std::int64_t(n[0]) * n[1]));
      for (int dz = -1; dz <= 1; ++dz)
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx) {
            if (!mask.geometry.contains_index(i + dx, j + dy, k + dz)) continue;
            const std::int64_t w = mask.geometry.linear_index(i + dx, j + dy, k + dz);
            if (mask.data[std::size_t(w)] != 0 && label[std::size_t(w)] == 0) {
              label[std::size_t(w)] = id;
              stack.push_back(w);
            }
          }
    }
    sizes.push_back(count);
  }
  return sizes;
}

/// Robust location and scale of the tissue/noise: median and 1.4826 × MAD of the finite voxels
/// above the image minimum. Nothing when fewer than 16 such voxels or a zero MAD.
std::optional<std::pair<double, double>> robust_noise(const VolumeF& image) {
  float low = std::numeric_limits<float>::infinity();
  for (const float v : image.data)
    if (std::isfinite(v)) low = std::min(low, v);
  std::vector<float> values;
  values.reserve(image.data.size());
  for (const float v : image.data)
    if (std::isfinite(v) && v > low) values.push_back(v);
  if (values.size() < 16) return std::nullopt;
  const auto mid = values.begin() + std::ptrdiff_t(values.size() / 2);
  std::nth_element(values.begin(), mid, values.end());
  const double median = *mid;
  for (float& v : values) v = float(std::abs(double(v) - median));
  std::nth_element(values.begin(), mid, values.end());
  const double sigma = 1.4826 * double(*mid);
  if (!(sigma > 0.0)) return std::nullopt;
  return std::make_pair(median, sigma);
}

/// The threshold and the name of the rule that gave it, or NaN when no rule applies.
std::pair<double, std::string> choose_threshold(const VolumeF& image,
                                                const VesselExtractionOptions& options) {
  if (std::isfinite(options.threshold)) return {options.threshold, "given"};
  if (options.threshold_method == ThresholdMethod::VESSEL_CONTRAST) return {std::nan(""), ""};
  if (options.threshold_method == ThresholdMethod::TISSUE_PEAK) {
    if (const auto t = tissue_peak_threshold(image, options.tail_fraction, options.histogram))
      return {*t, "tissue peak"};
    if (const auto t = otsu_threshold(image, options.histogram)) return {*t, "Otsu (fallback)"};
  } else if (const auto t = otsu_threshold(image, options.histogram)) {
    return {*t, "Otsu"};
  }
  return {std::nan(""), ""};
}

/// Removes the connected pieces of `graph` shorter than max(min_length, elongation × their
/// largest radius) and the nodes they leave unused; returns how many pieces went.
int remove_short_pieces(VesselGraph& graph, double min_length, double elongation) {
  if (graph.branches.empty() || (min_length <= 0.0 && elongation <= 0.0)) return 0;
  std::vector<index_t> parent(graph.nodes.size());
  std::iota(parent.begin(), parent.end(), index_t(0));
  const auto find = [&](index_t a) {
    while (parent[std::size_t(a)] != a)
      a = parent[std::size_t(a)] = parent[std::size_t(parent[std::size_t(a)])];
    return a;
  };
  for (const auto& b : graph.branches) parent[std::size_t(find(b.from))] = find(b.to);
  std::vector<double> length(graph.nodes.size(), 0.0), radius(graph.nodes.size(), 0.0);
  for (const auto& b : graph.branches) {
    const auto root = std::size_t(find(b.from));
    length[root] += polyline_length(b.points);
    for (const double r : b.radius) radius[root] = std::max(radius[root], r);
  }
  std::vector<std::uint8_t> keep(graph.nodes.size(), 0);
  int removed = 0;
  for (std::size_t n = 0; n < graph.nodes.size(); ++n)
    if (find(index_t(n)) == index_t(n) && length[n] > 0.0) {
      if (length[n] >= std::max(min_length, elongation * radius[n]))
        keep[n] = 1;
      else
        ++removed;
    }
  if (removed == 0) return 0;
  std::vector<index_t> new_index(graph.nodes.size(), -1);
  std::vector<VesselGraph::Node> nodes;
  for (std::size_t n = 0; n < graph.nodes.size(); ++n)
    if (keep[std::size_t(find(index_t(n)))] != 0) {
      new_index[n] = index_t(nodes.size());
      nodes.push_back(graph.nodes[n]);
    }
  std::vector<VesselGraph::Branch> branches;
  for (auto& b : graph.branches)
    if (new_index[std::size_t(b.from)] >= 0) {
      b.from = new_index[std::size_t(b.from)];
      b.to = new_index[std::size_t(b.to)];
      branches.push_back(std::move(b));
    }
  graph.nodes = std::move(nodes);
  graph.branches = std::move(branches);
  return removed;
}

VesselExtractionResult empty_result(VesselExtractionResult result, const std::string& why) {
  result.status = VesselStatus::EMPTY;
  result.message = why;
  logger().warn("vessel extraction: {}", why);
  return result;
}

}  // namespace

std::string VesselExtractionOptions::validate() const {
  std::ostringstream why;
  if (std::isinf(threshold)) why << "threshold must be finite or NaN (automatic); ";
  if (!(tail_fraction > 0.0 && tail_fraction < 1.0))
    why << "tail_fraction must lie in (0, 1), got " << tail_fraction << "; ";
  if (histogram.bins < 2) why << "histogram.bins must be ≥ 2, got " << histogram.bins << "; ";
  if (histogram.smoothing_half_width < 0) why << "histogram.smoothing_half_width must be ≥ 0; ";
  if (!(prefilter_sigma_mm >= 0.0) || std::isinf(prefilter_sigma_mm))
    why << "prefilter_sigma_mm must be ≥ 0 and finite, got " << prefilter_sigma_mm << "; ";
  if (!(noise_floor_k >= 0.0) || std::isinf(noise_floor_k))
    why << "noise_floor_k must be ≥ 0 and finite, got " << noise_floor_k << "; ";
  if (!(hysteresis_k >= 0.0) || std::isinf(hysteresis_k))
    why << "hysteresis_k must be ≥ 0 and finite, got " << hysteresis_k << "; ";
  if (!(min_component_mm3 >= 0.0))
    why << "min_component_mm3 must be ≥ 0, got " << min_component_mm3 << "; ";
  if (max_components < 0) why << "max_components must be ≥ 0, got " << max_components << "; ";
  if (!(spurs.min_length_mm >= 0.0) || !(spurs.radius_factor >= 0.0))
    why << "spur pruning lengths must be ≥ 0; ";
  if (!(min_piece_length_mm >= 0.0) || !(min_piece_elongation >= 0.0))
    why << "min_piece_length_mm and min_piece_elongation must be ≥ 0; ";
  if (smoothing_passes < 0) why << "smoothing_passes must be ≥ 0; ";
  if (!(resample_step_mm >= 0.0) || std::isinf(resample_step_mm))
    why << "resample_step_mm must be ≥ 0 and finite, got " << resample_step_mm << "; ";
  if (!(support_edge_margin_mm >= 0.0) || std::isinf(support_edge_margin_mm))
    why << "support_edge_margin_mm must be ≥ 0 and finite, got " << support_edge_margin_mm << "; ";
  std::string text = why.str();
  if (!text.empty()) text.resize(text.size() - 2);
  return text;
}

VesselExtractionResult extract_vessels(const VolumeF& image,
                                       const VesselExtractionOptions& options) {
  const std::string invalid = options.validate();
  BS_VERIFY(invalid.empty(), "vessel extraction options: " << invalid);
  BS_VERIFY(image.components == 1,
            "vessel extraction needs a one-component volume, got " << image.components);
  BS_VERIFY(image.data.size() == std::size_t(image.geometry.voxel_count()),
            "vessel extraction: volume holds " << image.data.size() << " values for "
                                               << image.geometry.voxel_count() << " voxels");
  VesselExtractionResult result;
  if (image.empty()) return empty_result(result, "empty volume (no voxels)");
  {  // counted by planes on threads
    const ImageGeometry& g = image.geometry;
    const std::size_t plane = std::size_t(g.size[0]) * std::size_t(g.size[1]);
    std::vector<std::int64_t> per_plane(std::size_t(g.size[2]), 0);
    filters::parallel_for(g.size[2], [&](int k0, int k1) {
      for (int k = k0; k < k1; ++k)
        per_plane[std::size_t(k)] =
            std::count_if(image.data.begin() + std::ptrdiff_t(plane * std::size_t(k)),
                          image.data.begin() + std::ptrdiff_t(plane * std::size_t(k + 1)),
                          [](float v) { return !std::isfinite(v); });
    });
    result.non_finite_voxels = std::accumulate(per_plane.begin(), per_plane.end(), std::int64_t(0));
  }
  if (result.non_finite_voxels > 0)
    logger().warn("vessel extraction: {} non-finite voxels treated as background",
                  result.non_finite_voxels);

  const VolumeF filtered_storage = options.prefilter_sigma_mm > 0.0
                                       ? filters::gaussian_filter(image, options.prefilter_sigma_mm)
                                       : VolumeF{};
  const VolumeF& filtered = options.prefilter_sigma_mm > 0.0 ? filtered_storage : image;

  double seed_threshold = -std::numeric_limits<double>::infinity();
  VesselContrast contrast;
  if (!std::isfinite(options.threshold) &&
      options.threshold_method == ThresholdMethod::VESSEL_CONTRAST) {
    contrast = vessel_contrast_threshold(image, filtered, options.contrast);
    result.vessel_level = contrast.vessel_level;
    result.noise_median = contrast.background_level;
    result.noise_sigma = contrast.noise_sigma;
    result.background_suppressed = contrast.background_suppressed;
    result.masked_fraction = contrast.masked_fraction;
    if (!std::isfinite(contrast.threshold)) return empty_result(result, contrast.empty_reason);
    result.threshold = contrast.threshold;
    result.threshold_rule = contrast.rule;
    if (!contrast.warning.empty()) result.warnings.push_back(contrast.warning);
    if (options.hysteresis_k > 0.0) {
      seed_threshold = std::max(result.threshold, contrast.background_level +
                                                      options.hysteresis_k * contrast.noise_sigma);
      result.seed_threshold = seed_threshold;
      result.threshold_rule += " + hysteresis";
    }
  } else {
    std::tie(result.threshold, result.threshold_rule) = choose_threshold(image, options);
    if (!std::isfinite(result.threshold))
      return empty_result(result,
                          "no threshold: the image has fewer than two distinct finite values");
    if (!std::isfinite(options.threshold) &&
        (options.noise_floor_k > 0.0 || options.hysteresis_k > 0.0)) {
      if (auto noise = robust_noise(image)) {
        // Measured on the raw image (the filtered one has halos round every bright structure),
        // scaled to the filtered image as for white noise.
        noise->second *= filters::gaussian_noise_gain(image.geometry, options.prefilter_sigma_mm);
        result.noise_median = noise->first;
        result.noise_sigma = noise->second;
        const double floor = noise->first + options.noise_floor_k * noise->second;
        if (options.noise_floor_k > 0.0 && floor > result.threshold) {
          result.threshold = floor;
          result.threshold_rule = "noise floor";
        }
        if (options.hysteresis_k > 0.0) {
          seed_threshold =
              std::max(result.threshold, noise->first + options.hysteresis_k * noise->second);
          result.seed_threshold = seed_threshold;
          result.threshold_rule += " + hysteresis";
        }
      }
    }
  }

  // Foreground and its bounding box.
  const ImageGeometry& g = image.geometry;
  Eigen::Vector3i lo = g.size, hi = Eigen::Vector3i::Constant(-1);
  {  // planes on threads: per-plane counts and boxes, combined (sums, minima, maxima: exact)
    std::vector<std::int64_t> count(std::size_t(g.size[2]), 0);
    std::vector<Eigen::Vector3i> plane_lo(std::size_t(g.size[2]), g.size),
        plane_hi(std::size_t(g.size[2]), Eigen::Vector3i::Constant(-1));
    filters::parallel_for(g.size[2], [&](int k0, int k1) {
      for (int k = k0; k < k1; ++k)
        for (int j = 0; j < g.size[1]; ++j)
          for (int i = 0; i < g.size[0]; ++i)
            if (filtered.at(i, j, k) >= result.threshold) {  // false for NaN
              ++count[std::size_t(k)];
              plane_lo[std::size_t(k)] =
                  plane_lo[std::size_t(k)].cwiseMin(Eigen::Vector3i(i, j, k));
              plane_hi[std::size_t(k)] =
                  plane_hi[std::size_t(k)].cwiseMax(Eigen::Vector3i(i, j, k));
            }
    });
    for (std::size_t k = 0; k < count.size(); ++k) {
      result.foreground_voxels += count[k];
      lo = lo.cwiseMin(plane_lo[k]);
      hi = hi.cwiseMax(plane_hi[k]);
    }
  }
  if (result.foreground_voxels == 0) {
    std::ostringstream why;
    why << "no voxel at or above the threshold " << result.threshold << " ("
        << result.threshold_rule << ")";
    return empty_result(result, why.str());
  }
  Mask mask(crop_geometry(g, lo, hi));
  for (int k = lo[2]; k <= hi[2]; ++k)
    for (int j = lo[1]; j <= hi[1]; ++j)
      for (int i = lo[0]; i <= hi[0]; ++i)
        mask.at(i - lo[0], j - lo[1], k - lo[2]) = filtered.at(i, j, k) >= result.threshold ? 1 : 0;

  // Components above the minimum size, at most max_components of the largest.
  std::vector<int> label;
  std::vector<std::int64_t> sizes = label_components(mask, label);
  result.components_found = int(sizes.size());
  if (std::isfinite(seed_threshold)) {  // hysteresis: components without a seed voxel go
    std::vector<std::uint8_t> seeded(sizes.size() + 1, 0);
    for (int k = lo[2]; k <= hi[2]; ++k)
      for (int j = lo[1]; j <= hi[1]; ++j)
        for (int i = lo[0]; i <= hi[0]; ++i)
          if (filtered.at(i, j, k) >= seed_threshold)
            seeded[std::size_t(
                label[std::size_t(mask.geometry.linear_index(i - lo[0], j - lo[1], k - lo[2]))])] =
                1;
    for (std::size_t c = 0; c < sizes.size(); ++c)
      if (seeded[c + 1] == 0) sizes[c] = 0;
  }
  if (contrast.vesselness_max > 0.0 && options.min_tubular_fraction > 0.0) {
    // Shape rule: the share of each component's voxels in tubular vesselness cells.
    std::vector<std::int64_t> tubular(sizes.size() + 1, 0);
    const VolumeF& v = contrast.vesselness;
    const float level = float(options.tubular_vesselness * contrast.vesselness_max);
    for (int k = lo[2]; k <= hi[2]; ++k)
      for (int j = lo[1]; j <= hi[1]; ++j)
        for (int i = lo[0]; i <= hi[0]; ++i) {
          const int c =
              label[std::size_t(mask.geometry.linear_index(i - lo[0], j - lo[1], k - lo[2]))];
          if (c != 0 &&
              v.at(i / contrast.factor[0], j / contrast.factor[1], k / contrast.factor[2]) >= level)
            ++tubular[std::size_t(c)];
        }
    for (std::size_t c = 0; c < sizes.size(); ++c)
      if (sizes[c] > 0 &&
          double(tubular[c + 1]) < options.min_tubular_fraction * double(sizes[c])) {
        if (double(sizes[c]) * g.spacing.prod() >= options.min_component_mm3)
          ++result.components_not_tubular;
        sizes[c] = 0;
      }
  }
  const double voxel_mm3 = g.spacing.prod();
  std::vector<int> order(sizes.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(),
            [&](int a, int b) { return sizes[std::size_t(a)] > sizes[std::size_t(b)]; });
  std::vector<std::uint8_t> keep(sizes.size() + 1, 0);
  for (const int c : order) {
    if (double(sizes[std::size_t(c)]) * voxel_mm3 < options.min_component_mm3) break;
    if (options.max_components > 0 && result.components_kept >= options.max_components) break;
    keep[std::size_t(c) + 1] = 1;
    ++result.components_kept;
    result.kept_volume_mm3 += double(sizes[std::size_t(c)]) * voxel_mm3;
  }
  if (result.components_kept == 0) {
    std::ostringstream why;
    why << "no component of at least " << options.min_component_mm3 << " mm³ above the threshold "
        << result.threshold << " (" << result.components_found << " found";
    if (result.components_not_tubular > 0)
      why << ", " << result.components_not_tubular << " large but not tubular";
    why << ")";
    return empty_result(result, why.str());
  }
  for (std::size_t v = 0; v < mask.data.size(); ++v) mask.data[v] = keep[std::size_t(label[v])];

  // Radii from the distance to the background: the wall lies about half a voxel inside the
  // nearest background voxel centre.
  VolumeF radius = distance_to_background(mask);
  const double half_voxel = 0.5 * g.spacing.minCoeff();
  for (float& r : radius.data) r = float(std::max(double(r) - half_voxel, half_voxel));

  thin_to_curves(mask);
  result.skeleton_voxels = std::count(mask.data.begin(), mask.data.end(), std::uint8_t(1));
  result.graph = graph_from_skeleton(mask, radius);
  result.spurs_pruned = prune_spurs(result.graph, options.spurs);
  result.pieces_removed =
      remove_short_pieces(result.graph, options.min_piece_length_mm, options.min_piece_elongation);
  smooth_branches(result.graph, options.smoothing_passes);
  if (options.resample_step_mm > 0.0) resample_branches(result.graph, options.resample_step_mm);
  if (options.drop_at_support_edge) {
    const SupportEdgeResult edge = drop_points_at_support_edge(
        result.graph, image, result.foreground_voxels, options.support_edge_margin_mm);
    result.points_at_support_edge = edge.dropped;
    result.sector_found = edge.sector_found;
    if (result.graph.branches.empty())
      return empty_result(result,
                          "every centreline point lies at the side of the "
                          "ultrasound sector (vessels cut by its mask)");
  }

  result.branch_count = int(result.graph.branches.size());
  result.junction_count = result.graph.junction_count();
  result.endpoint_count = result.graph.endpoint_count();
  result.total_length_mm = result.graph.total_length();
  if (result.branch_count == 0)
    return empty_result(result, "the kept components thin to isolated points (no branch)");
  result.status = VesselStatus::OK;
  if (result.total_length_mm < options.few_vessels_mm) {
    std::ostringstream few;
    few << "few vessels: " << result.branch_count << " branches, " << result.total_length_mm
        << " mm in all (less than " << options.few_vessels_mm << " mm)";
    result.warnings.push_back(few.str());
  }
  for (const std::string& w : result.warnings) logger().warn("vessel extraction: {}", w);
  std::ostringstream summary;
  summary << "threshold " << result.threshold << " (" << result.threshold_rule << "), "
          << result.components_kept << "/" << result.components_found << " components, "
          << result.branch_count << " branches, " << result.junction_count << " junctions, "
          << result.total_length_mm << " mm";
  if (result.points_at_support_edge > 0)
    summary << ", " << result.points_at_support_edge << " points at the sector's side dropped";
  result.message = summary.str();
  logger().info("vessel extraction: {}", result.message);
  return result;
}

}  // namespace brainshift::imaging
