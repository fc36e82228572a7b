#include "imaging/filters/vesselness.hpp"

#include "imaging/filters/gaussian.hpp"
#include "imaging/filters/order_statistic.hpp"
#include "imaging/filters/parallel.hpp"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <sstream>

namespace brainshift::imaging::filters {
namespace {

/// Hessian (mm⁻²) of `s` at voxel (i, j, k) by central differences, faces repeated.
Eigen::Matrix3d hessian_at(const VolumeF& s, int i, int j, int k, const Vector3d& inv_h) {
  const Eigen::Vector3i& n = s.geometry.size;
  if (i > 0 && j > 0 && k > 0 && i < n[0] - 1 && j < n[1] - 1 && k < n[2] - 1) {
    // Interior: direct offsets.
    const std::int64_t sx = 1, sy = n[0], sz = std::int64_t(n[0]) * n[1];
    const float* p = &s.data[std::size_t(s.geometry.linear_index(i, j, k))];
    const double c2 = 2.0 * p[0];
    Eigen::Matrix3d h;
    h(0, 0) = (p[sx] - c2 + p[-sx]) * inv_h[0] * inv_h[0];
    h(1, 1) = (p[sy] - c2 + p[-sy]) * inv_h[1] * inv_h[1];
    h(2, 2) = (p[sz] - c2 + p[-sz]) * inv_h[2] * inv_h[2];
    h(0, 1) = h(1, 0) =
        (p[sx + sy] - p[sx - sy] - p[sy - sx] + p[-sx - sy]) * 0.25 * inv_h[0] * inv_h[1];
    h(0, 2) = h(2, 0) =
        (p[sx + sz] - p[sx - sz] - p[sz - sx] + p[-sx - sz]) * 0.25 * inv_h[0] * inv_h[2];
    h(1, 2) = h(2, 1) =
        (p[sy + sz] - p[sy - sz] - p[sz - sy] + p[-sy - sz]) * 0.25 * inv_h[1] * inv_h[2];
    return h;
  }
  const auto value = [&](int di, int dj, int dk) {
    return double(s.at(std::clamp(i + di, 0, n[0] - 1), std::clamp(j + dj, 0, n[1] - 1),
                       std::clamp(k + dk, 0, n[2] - 1)));
  };
  const double centre = value(0, 0, 0);
  Eigen::Matrix3d h;
  for (int a = 0; a < 3; ++a) {
    Eigen::Vector3i e = Eigen::Vector3i::Zero();
    e[a] = 1;
    h(a, a) = n[a] < 2 ? 0.0
                       : (value(e[0], e[1], e[2]) - 2.0 * centre + value(-e[0], -e[1], -e[2])) *
                             inv_h[a] * inv_h[a];
    for (int b = a + 1; b < 3; ++b) {
      Eigen::Vector3i f = Eigen::Vector3i::Zero();
      f[b] = 1;
      const Eigen::Vector3i p = e + f, m = e - f;
      const double d = (n[a] < 2 || n[b] < 2)
                           ? 0.0
                           : (value(p[0], p[1], p[2]) - value(m[0], m[1], m[2]) -
                              value(-m[0], -m[1], -m[2]) + value(-p[0], -p[1], -p[2])) *
                                 0.25 * inv_h[a] * inv_h[b];
      h(a, b) = h(b, a) = d;
    }
  }
  return h;
}

}  // namespace

std::string VesselnessOptions::validate() const {
  std::ostringstream why;
  if (scales_mm.empty()) why << "scales_mm must not be empty; ";
  for (const double s : scales_mm)
    if (!(s > 0.0) || !std::isfinite(s))
      why << "scales_mm must be > 0 and finite, got " << s << "; ";
  if (!(alpha > 0.0) || !(beta > 0.0)) why << "alpha and beta must be > 0; ";
  if (!(c_fraction > 0.0) || !std::isfinite(c_fraction))
    why << "c_fraction must be > 0, got " << c_fraction << "; ";
  std::string text = why.str();
  if (!text.empty()) text.resize(text.size() - 2);
  return text;
}

VolumeF frangi_vesselness(const VolumeF& image, const VesselnessOptions& options) {
  const std::string invalid = options.validate();
  BS_VERIFY(invalid.empty(), "vesselness options: " << invalid);
  BS_VERIFY(image.components == 1,
            "vesselness needs a one-component volume, got " << image.components);
  const ImageGeometry& g = image.geometry;
  VolumeF best(g, 1, 0.0F);
  if (image.empty()) return best;
  const double a2 = 2.0 * options.alpha * options.alpha, b2 = 2.0 * options.beta * options.beta;
  for (const double sigma : options.scales_mm) {
    // Scales of two or more voxels run on a grid coarsened so that σ stays ≈ 1–2 voxels: the
    // response of a tube that wide changes little over a voxel, and the cost falls by f³·f.
    Eigen::Vector3i factor;
    for (int a = 0; a < 3; ++a)
      factor[a] = std::max(1, int(std::floor(sigma / (2.0 * g.spacing[a]))));
    const VolumeF coarse =
        factor == Eigen::Vector3i::Ones() ? VolumeF{} : downsample(image, factor);
    const VolumeF& source = factor == Eigen::Vector3i::Ones() ? image : coarse;
    const ImageGeometry& h = source.geometry;
    const VolumeF s = gaussian_filter(source, sigma);
    const Vector3d inv_h = h.spacing.cwiseInverse();
    const double normalise = sigma * sigma;  // γ = 1 scale normalisation of second derivatives
    // Bright tubes are brighter than the image's median after smoothing: skip the rest.
    const auto finite_median = median_where(
        s.data.size(), [](std::size_t) { return true; }, [&s](std::size_t v) { return s.data[v]; });
    if (!finite_median) continue;
    const float median = finite_median->value;
    // Pass 1: Hessian norm (for c) where the trace is negative (bright ridges).
    std::vector<float> norm(s.data.size(), -1.0F);
    std::vector<double> largest_of(std::size_t(h.size[2]), 0.0);
    parallel_for(h.size[2], [&](int k0, int k1) {
      for (int k = k0; k < k1; ++k)
        for (int j = 0; j < h.size[1]; ++j)
          for (int i = 0; i < h.size[0]; ++i) {
            const std::size_t v = std::size_t(h.linear_index(i, j, k));
            if (!(s.data[v] > median)) continue;
            const Eigen::Matrix3d m = normalise * hessian_at(s, i, j, k, inv_h);
            if (m.trace() >= 0.0) continue;
            norm[v] = float(m.norm());
            largest_of[std::size_t(k)] = std::max(largest_of[std::size_t(k)], double(norm[v]));
          }
    });
    const double largest = *std::max_element(largest_of.begin(), largest_of.end());
    if (!(largest > 0.0)) continue;
    const double c2 = 2.0 * std::pow(options.c_fraction * largest, 2);
    // Pass 2: the eigenvalues where the structure term could beat the best response so far.
    parallel_for(g.size[2], [&](int k0, int k1) {
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig;
      for (int k = k0; k < k1; ++k)
        for (int j = 0; j < g.size[1]; ++j)
          for (int i = 0; i < g.size[0]; ++i) {
            const int ci = i / factor[0], cj = j / factor[1], ck = k / factor[2];
            const std::size_t v = std::size_t(h.linear_index(ci, cj, ck));
            if (norm[v] <= 0.0F) continue;
            float& out = best.at(i, j, k);
            const double structure = 1.0 - std::exp(-double(norm[v]) * norm[v] / c2);
            if (structure <= out) continue;
            eig.computeDirect(normalise * hessian_at(s, ci, cj, ck, inv_h), Eigen::EigenvaluesOnly);
            Vector3d l = eig.eigenvalues();
            std::sort(l.data(), l.data() + 3,
                      [](double x, double y) { return std::abs(x) < std::abs(y); });
            if (!(l[1] < 0.0 && l[2] < 0.0)) continue;
            const double ra = std::abs(l[1]) / std::abs(l[2]);
            const double rb = std::abs(l[0]) / std::sqrt(std::abs(l[1] * l[2]));
            out = std::max(
                out, float((1.0 - std::exp(-ra * ra / a2)) * std::exp(-rb * rb / b2) * structure));
          }
    });
  }
  return best;
}

}  // namespace brainshift::imaging::filters
