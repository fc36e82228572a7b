#include "imaging/footprint/footprint.hpp"

#include "core/error.hpp"
#include "core/logger.hpp"
#include "imaging/filters/gaussian.hpp"
#include "imaging/filters/separable.hpp"
#include "imaging/filters/trilinear.hpp"

#include <Eigen/QR>

#include <algorithm>
#include <array>
#include <cmath>
#include <sstream>
#include <vector>

namespace brainshift::imaging {
namespace {

constexpr float kMissing = std::numeric_limits<float>::quiet_NaN();

/// Probe frame: u lateral, v elevation, w axis (into the tissue), right-handed.
struct ProbeFrame {
  Vector3d centre;
  Vector3d u;
  Vector3d v;
  Vector3d w;
  [[nodiscard]] Vector3d world(double x, double y, double z) const {
    return centre + x * u + y * v + z * w;
  }
};

ProbeFrame make_frame(const ProbePose& pose) {
  BS_VERIFY(pose.face_centre.allFinite(),
            "probe face centre is not finite: " << pose.face_centre.transpose());
  BS_VERIFY(pose.axis.allFinite() && pose.axis.norm() > 1e-9,
            "probe axis must be a finite non-zero vector, got " << pose.axis.transpose());
  ProbeFrame f;
  f.centre = pose.face_centre;
  f.w = pose.axis.normalized();
  Vector3d lateral;
  if (pose.lateral) {
    BS_VERIFY(pose.lateral->allFinite(),
              "probe lateral direction is not finite: " << pose.lateral->transpose());
    lateral = *pose.lateral;
  } else {
    Eigen::Index least = 0;
    f.w.cwiseAbs().minCoeff(&least);
    lateral = Vector3d::Unit(least);
  }
  const Vector3d u = lateral - lateral.dot(f.w) * f.w;
  BS_VERIFY(u.norm() > 1e-6 * std::max(lateral.norm(), 1e-300),
            "probe lateral direction " << lateral.transpose() << " is parallel to the axis "
                                       << f.w.transpose());
  f.u = u.normalized();
  f.v = f.w.cross(f.u);
  return f;
}

/// Rays over the face (i lateral, j elevation) sampled along depth (k), k fastest.
struct RayGrid {
  int nu = 0;
  int nv = 0;
  int nd = 0;
  double step = 1.0;
  double dstep = 1.0;
  double d0 = 0.0;
  [[nodiscard]] double x(int i) const { return (i - 0.5 * (nu - 1)) * step; }
  [[nodiscard]] double y(int j) const { return (j - 0.5 * (nv - 1)) * step; }
  [[nodiscard]] double depth(double k) const { return d0 + k * dstep; }
  [[nodiscard]] int ray(int i, int j) const { return j * nu + i; }
  [[nodiscard]] std::size_t index(int i, int j, int k) const {
    return std::size_t(ray(i, j)) * std::size_t(nd) + std::size_t(k);
  }
  [[nodiscard]] int rays() const { return nu * nv; }
};

/// Trilinear interpolation at world point p; missing (NaN) outside the grid (beyond half a voxel
/// from the outer centres) or when less than half the interpolation weight is on finite voxels.
float sample(const VolumeF& image, const Vector3d& p) {
  return filters::sample_trilinear(image, image.geometry.world_to_index(p),
                                   filters::MissingData::RENORMALISE);
}

/// One separable Gaussian pass along `axis` (0: i, 1: j, 2: k) with missing-data normalisation:
/// the kernel is truncated at the grid's ends and renormalised over finite samples; a result
/// with less than half the (truncated) kernel weight on finite samples is missing.
void gaussian_pass(std::vector<float>& data, const RayGrid& grid, int axis, double sigma) {
  const std::vector<double> kernel = filters::gaussian_kernel(sigma, 0);
  if (kernel.empty()) return;
  // Memory order of the ray grid: k (depth) fastest, then i, then j.
  constexpr int memory_axis[3] = {1, 2, 0};
  filters::filter_axis(data, Eigen::Vector3i(grid.nd, grid.nu, grid.nv), memory_axis[axis], kernel,
                       filters::MissingData::RENORMALISE);
}

/// The volume resampled on the rays of `grid` and low-pass filtered there. The filter runs on a
/// grid padded by 3σ on every side (then cropped), so that the rays at the aperture's edges get
/// a full kernel: a one-sided kernel would average a sloping band towards the inner depths and
/// flatten the surface there.
std::vector<float> filtered_samples(const VolumeF& image, const ProbeFrame& frame,
                                    const RayGrid& grid, double sigma_mm,
                                    std::int64_t& missing_raw) {
  const int mu = int(std::ceil(3.0 * sigma_mm / grid.step));
  const int md = int(std::ceil(3.0 * sigma_mm / grid.dstep));
  RayGrid padded = grid;
  padded.nu += 2 * mu;
  padded.nv += 2 * mu;
  padded.nd += 2 * md;
  padded.d0 -= md * grid.dstep;
  std::vector<float> p(std::size_t(padded.rays()) * std::size_t(padded.nd));
  for (int j = 0; j < padded.nv; ++j)
    for (int i = 0; i < padded.nu; ++i)
      for (int k = 0; k < padded.nd; ++k)
        p[padded.index(i, j, k)] =
            sample(image, frame.world(padded.x(i), padded.y(j), padded.depth(k)));
  missing_raw = 0;
  for (int j = mu; j < mu + grid.nv; ++j)
    for (int i = mu; i < mu + grid.nu; ++i)
      for (int k = md; k < md + grid.nd; ++k)
        missing_raw += std::isfinite(p[padded.index(i, j, k)]) ? 0 : 1;
  gaussian_pass(p, padded, 2, sigma_mm / grid.dstep);
  gaussian_pass(p, padded, 0, sigma_mm / grid.step);
  gaussian_pass(p, padded, 1, sigma_mm / grid.step);
  std::vector<float> f(std::size_t(grid.rays()) * std::size_t(grid.nd));
  for (int j = 0; j < grid.nv; ++j)
    for (int i = 0; i < grid.nu; ++i)
      for (int k = 0; k < grid.nd; ++k)
        f[grid.index(i, j, k)] = p[padded.index(i + mu, j + mu, k + md)];
  return f;
}

/// The chosen threshold, or a reason there is none (then NaN).
double choose_threshold(const std::vector<float>& finite, const FootprintOptions& o,
                        FootprintResult& r, std::string& why) {
  if (std::isfinite(o.threshold)) {
    r.threshold_rule = "given";
    return o.threshold;
  }
  const float top = *std::max_element(finite.begin(), finite.end());
  if (o.threshold_rule == FootprintThreshold::FRACTION_OF_MAX) {
    r.threshold_rule = "fraction of max";
    if (!(top > 0.0f)) {
      why = "the image under the probe face is dark (maximum " + std::to_string(top) + ")";
      return std::numeric_limits<double>::quiet_NaN();
    }
    return o.threshold_fraction * top;
  }
  r.threshold_rule = "Otsu";
  ImageGeometry g;
  g.size = Eigen::Vector3i(int(finite.size()), 1, 1);
  VolumeF slab(g);
  slab.data = finite;
  const auto t = otsu_threshold(slab, o.histogram);
  if (!t) why = "the image under the probe face is constant";
  return t.value_or(std::numeric_limits<double>::quiet_NaN());
}

/// Depth (mm) of the band on one filtered ray, NaN when there is none.
double band_depth(const float* f, const RayGrid& grid, double threshold,
                  const FootprintOptions& o) {
  int k = 0;
  while (k < grid.nd && !std::isfinite(f[k])) ++k;
  const int first = k;  // first sample with data
  while (k < grid.nd && !(f[k] >= threshold)) ++k;
  // None, or right after missing data: the band may lie in the gap, and a deeper crossing would
  // be tissue, so the ray has no band (unless the gap is the outside in front of the face).
  const bool leading = o.leading_missing_is_outside && k == first;
  if (k == grid.nd || (k > 0 && !std::isfinite(f[k - 1]) && !leading))
    return std::numeric_limits<double>::quiet_NaN();
  if (o.depth_rule == FootprintDepthRule::THRESHOLD_CROSSING) {
    if (k == 0) return grid.depth(0);
    const double t = (threshold - f[k - 1]) / double(f[k] - f[k - 1]);
    return grid.depth(k - 1 + std::clamp(t, 0.0, 1.0));
  }
  const int last = std::min(grid.nd - 1, k + int(std::ceil(o.band_search_mm / grid.dstep)));
  int peak = k;
  while (peak < last && std::isfinite(f[peak + 1]) && f[peak + 1] >= f[peak]) ++peak;
  double offset = 0.0;
  if (peak > 0 && peak < grid.nd - 1 && std::isfinite(f[peak - 1]) && std::isfinite(f[peak + 1])) {
    const double curvature = double(f[peak - 1]) - 2.0 * f[peak] + f[peak + 1];
    if (curvature < 0.0)
      offset = std::clamp(0.5 * (f[peak - 1] - f[peak + 1]) / curvature, -0.5, 0.5);
  }
  return grid.depth(peak + offset);
}

/// Labels the depth-continuous 8-connected patches of rays with a band; returns the rays of the
/// largest and the number of patches.
std::vector<int> largest_patch(const std::vector<double>& depth, const RayGrid& grid,
                               double max_jump, int& patches) {
  std::vector<int> label(depth.size(), -1);
  std::vector<int> best;
  std::vector<int> current;
  patches = 0;
  for (int seed = 0; seed < grid.rays(); ++seed) {
    if (label[std::size_t(seed)] >= 0 || !std::isfinite(depth[std::size_t(seed)])) continue;
    current.assign(1, seed);
    label[std::size_t(seed)] = patches;
    for (std::size_t head = 0; head < current.size(); ++head) {
      const int r = current[head];
      const int i = r % grid.nu;
      const int j = r / grid.nu;
      for (int dj = -1; dj <= 1; ++dj)
        for (int di = -1; di <= 1; ++di) {
          const int ni = i + di;
          const int nj = j + dj;
          if (ni < 0 || nj < 0 || ni >= grid.nu || nj >= grid.nv) continue;
          const int nr = grid.ray(ni, nj);
          const double d = depth[std::size_t(nr)];
          if (label[std::size_t(nr)] >= 0 || !std::isfinite(d)) continue;
          if (std::abs(d - depth[std::size_t(r)]) > max_jump) continue;
          label[std::size_t(nr)] = patches;
          current.push_back(nr);
        }
    }
    ++patches;
    if (current.size() > best.size()) best.swap(current);
  }
  return best;
}

/// Local least-squares fit z(x, y) of the patch depths around (x0, y0): a quadric
/// c0 + c1 dx + c2 dy + c3 dx² + c4 dx dy + c5 dy² when well posed, else a plane; one refit
/// without residuals beyond 3 robust standard deviations. Returns (c0, ∂z/∂x, ∂z/∂y) at the node,
/// or nothing for too few or degenerate points.
std::optional<Vector3d> fit_depth(const std::vector<Vector3d>& pts, double x0, double y0,
                                  const FootprintOptions& o, double floor_mm) {
  std::vector<Vector3d> use = pts;
  std::optional<Vector3d> fit;
  for (int pass = 0; pass < 2; ++pass) {
    if (int(use.size()) < std::max(o.min_fit_points, 3)) return fit;
    const bool quadric = use.size() >= 12;
    const int cols = quadric ? 6 : 3;
    Eigen::MatrixXd A(Eigen::Index(use.size()), cols);
    Eigen::VectorXd b(Eigen::Index(use.size()));
    for (std::size_t n = 0; n < use.size(); ++n) {
      const double dx = use[n].x() - x0;
      const double dy = use[n].y() - y0;
      const auto row = Eigen::Index(n);
      A(row, 0) = 1.0;
      A(row, 1) = dx;
      A(row, 2) = dy;
      if (quadric) {
        A(row, 3) = dx * dx;
        A(row, 4) = dx * dy;
        A(row, 5) = dy * dy;
      }
      b[row] = use[n].z();
    }
    Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(A);
    Eigen::VectorXd c;
    if (qr.rank() == cols) {
      c = qr.solve(b);
    } else {
      Eigen::ColPivHouseholderQR<Eigen::MatrixXd> plane(A.leftCols(3));
      if (plane.rank() < 3) return fit;
      c = Eigen::VectorXd::Zero(cols);
      c.head(3) = plane.solve(b);
    }
    if (!c.allFinite()) return fit;
    fit = Vector3d(c[0], c[1], c[2]);
    if (pass == 1) break;
    const Eigen::VectorXd res = (A * c - b).cwiseAbs();
    std::vector<double> sorted(res.data(), res.data() + res.size());
    std::nth_element(sorted.begin(), sorted.begin() + long(sorted.size() / 2), sorted.end());
    const double limit = std::max(3.0 * 1.4826 * sorted[sorted.size() / 2], floor_mm);
    std::vector<Vector3d> kept;
    for (std::size_t n = 0; n < use.size(); ++n)
      if (res[Eigen::Index(n)] <= limit) kept.push_back(use[n]);
    if (kept.size() == use.size()) break;
    use.swap(kept);
  }
  return fit;
}

/// Checks the band contrast (mean of the samples ≥ threshold over the mean of those below);
/// returns why the threshold is refused, empty when accepted.
std::string contrast_check(const std::vector<float>& finite, double threshold, double min_contrast,
                           double& contrast) {
  double above = 0.0;
  double below = 0.0;
  std::size_t n_above = 0;
  for (float v : finite) {
    if (v >= threshold) {
      above += v;
      ++n_above;
    } else {
      below += v;
    }
  }
  if (n_above == 0)
    return "nothing under the probe face reaches the threshold " + std::to_string(threshold);
  if (n_above == finite.size())
    return "everything under the probe face is above the threshold " + std::to_string(threshold);
  const double mean_above = above / double(n_above);
  const double mean_below = below / double(finite.size() - n_above);
  contrast = mean_below > 0.0 ? mean_above / mean_below : std::numeric_limits<double>::max();
  if (mean_above > 0.0 && contrast >= min_contrast) return {};
  std::ostringstream s;
  s << "band contrast " << contrast << " is below min_contrast " << min_contrast
    << " (dark or band-less image)";
  return s.str();
}

/// Lattice of step `spacing` (mm) through the patch centroid on the face; a node counts when
/// its nearest ray is in the patch. A patch too small to hold a node gets its ray nearest the
/// centroid.
std::vector<std::array<double, 2>> lattice_nodes(const std::vector<int>& patch,
                                                 const std::vector<char>& in_patch,
                                                 const RayGrid& grid, double spacing) {
  double cx = 0.0;
  double cy = 0.0;
  for (int ray : patch) {
    cx += grid.x(ray % grid.nu);
    cy += grid.y(ray / grid.nu);
  }
  cx /= double(patch.size());
  cy /= double(patch.size());
  const auto nearest_ray = [&](double x, double y) {
    const int i = int(std::lround(x / grid.step + 0.5 * (grid.nu - 1)));
    const int j = int(std::lround(y / grid.step + 0.5 * (grid.nv - 1)));
    if (i < 0 || j < 0 || i >= grid.nu || j >= grid.nv) return -1;
    return grid.ray(i, j);
  };
  std::vector<std::array<double, 2>> nodes;
  const int mu = int(std::ceil((0.5 * (grid.nu - 1) * grid.step + std::abs(cx)) / spacing));
  const int mv = int(std::ceil((0.5 * (grid.nv - 1) * grid.step + std::abs(cy)) / spacing));
  for (int b = -mv; b <= mv; ++b)
    for (int a = -mu; a <= mu; ++a) {
      const double x = cx + a * spacing;
      const double y = cy + b * spacing;
      const int ray = nearest_ray(x, y);
      if (ray >= 0 && in_patch[std::size_t(ray)]) nodes.push_back({x, y});
    }
  if (!nodes.empty()) return nodes;
  int best = patch.front();
  double best_d2 = std::numeric_limits<double>::max();
  for (int ray : patch) {
    const double d2 =
        std::pow(grid.x(ray % grid.nu) - cx, 2) + std::pow(grid.y(ray / grid.nu) - cy, 2);
    if (d2 < best_d2) {
      best_d2 = d2;
      best = ray;
    }
  }
  nodes.push_back({grid.x(best % grid.nu), grid.y(best / grid.nu)});
  return nodes;
}

/// Rays of the patch within `radius` of (x0, y0), as (x, y, depth).
void gather_disc(const RayGrid& grid, const std::vector<double>& depth,
                 const std::vector<char>& in_patch, double x0, double y0, double radius,
                 std::vector<Vector3d>& local) {
  local.clear();
  const int reach = int(std::ceil(radius / grid.step));
  const int i0 = int(std::lround(x0 / grid.step + 0.5 * (grid.nu - 1)));
  const int j0 = int(std::lround(y0 / grid.step + 0.5 * (grid.nv - 1)));
  for (int j = std::max(0, j0 - reach); j <= std::min(grid.nv - 1, j0 + reach); ++j)
    for (int i = std::max(0, i0 - reach); i <= std::min(grid.nu - 1, i0 + reach); ++i) {
      const int ray = grid.ray(i, j);
      if (!in_patch[std::size_t(ray)] || std::hypot(grid.x(i) - x0, grid.y(j) - y0) > radius)
        continue;
      local.emplace_back(grid.x(i), grid.y(j), depth[std::size_t(ray)]);
    }
}

/// Local fit at each lattice node: the point at the fitted depth, the normal of the fitted
/// surface. Where the disc is less than ¾ full (the patch's edge), it grows by steps of 25 % up
/// to twice `fit_radius_mm`, so that one-sided fits keep about as many rays as inner ones.
void fit_nodes(const std::vector<std::array<double, 2>>& nodes, const RayGrid& grid,
               const std::vector<double>& depth, const std::vector<char>& in_patch,
               const ProbeFrame& frame, const FootprintOptions& o, std::vector<Vector3d>& points,
               std::vector<Vector3d>& normals, int& skipped) {
  constexpr double kPi = 3.14159265358979323846;
  const double full = kPi * o.fit_radius_mm * o.fit_radius_mm / (grid.step * grid.step);
  std::vector<Vector3d> local;
  for (const auto& [x0, y0] : nodes) {
    for (double radius = o.fit_radius_mm; radius <= 2.0 * o.fit_radius_mm + 1e-9; radius *= 1.25) {
      gather_disc(grid, depth, in_patch, x0, y0, radius, local);
      if (double(local.size()) >= 0.75 * full) break;
    }
    const auto fit = fit_depth(local, x0, y0, o, /*floor_mm=*/grid.dstep);
    if (!fit) {
      ++skipped;
      continue;
    }
    const Vector3d p = frame.world(x0, y0, (*fit)[0]);
    const Vector3d n = (frame.w - (*fit)[1] * frame.u - (*fit)[2] * frame.v).normalized();
    if (!p.allFinite() || !n.allFinite()) {
      ++skipped;
      continue;
    }
    points.push_back(p);
    normals.push_back(n);
  }
}

FootprintResult no_band(FootprintResult r, const std::string& why) {
  r.status = FootprintStatus::NO_BAND;
  r.message = "no contact band found: " + why;
  r.points.resize(0, 3);
  r.normals.resize(0, 3);
  logger().info("footprint: {}", r.message);
  return r;
}

}  // namespace

std::string FootprintOptions::validate() const {
  std::ostringstream e;
  const auto positive = [&](double value, const char* name) {
    if (!(std::isfinite(value) && value > 0.0)) e << name << " = " << value << " must be > 0; ";
  };
  positive(aperture_width_mm, "aperture_width_mm");
  positive(aperture_elevation_mm, "aperture_elevation_mm");
  positive(grid_step_mm, "grid_step_mm");
  positive(depth_step_mm, "depth_step_mm");
  positive(band_search_mm, "band_search_mm");
  positive(max_depth_jump_mm, "max_depth_jump_mm");
  positive(sample_spacing_mm, "sample_spacing_mm");
  positive(fit_radius_mm, "fit_radius_mm");
  positive(min_contrast, "min_contrast");
  if (!(std::isfinite(min_depth_mm) && min_depth_mm >= 0.0))
    e << "min_depth_mm = " << min_depth_mm << " must be >= 0; ";
  if (!(std::isfinite(max_depth_mm) && max_depth_mm > min_depth_mm + depth_step_mm))
    e << "max_depth_mm = " << max_depth_mm << " must exceed min_depth_mm + depth_step_mm; ";
  if (!(std::isfinite(smoothing_sigma_mm) && smoothing_sigma_mm >= 0.0))
    e << "smoothing_sigma_mm = " << smoothing_sigma_mm << " must be >= 0; ";
  if (std::isinf(threshold)) e << "threshold must be finite or NaN (automatic); ";
  if (!(threshold_fraction > 0.0 && threshold_fraction < 1.0))
    e << "threshold_fraction = " << threshold_fraction << " must be in (0, 1); ";
  if (!(std::isfinite(min_patch_area_mm2) && min_patch_area_mm2 >= 0.0))
    e << "min_patch_area_mm2 = " << min_patch_area_mm2 << " must be >= 0; ";
  if (min_fit_points < 3) e << "min_fit_points = " << min_fit_points << " must be >= 3; ";
  if (histogram.bins < 2) e << "histogram.bins = " << histogram.bins << " must be >= 2; ";
  const double rays = (aperture_width_mm / grid_step_mm + 1) *
                      (aperture_elevation_mm / grid_step_mm + 1) *
                      ((max_depth_mm - min_depth_mm) / depth_step_mm + 1);
  if (std::isfinite(rays) && rays > 5e7)
    e << "the ray grid would hold " << rays
      << " samples (> 5e7): coarser steps or a smaller aperture; ";
  std::string s = e.str();
  if (s.size() >= 2) s.resize(s.size() - 2);
  return s;
}

FootprintResult extract_footprint(const VolumeF& bmode, const ProbePose& pose,
                                  const FootprintOptions& o) {
  const std::string invalid = o.validate();
  BS_VERIFY(invalid.empty(), "footprint options: " << invalid);
  BS_VERIFY(bmode.components == 1,
            "the B-mode volume has " << bmode.components << " components, expected 1");
  BS_VERIFY(std::int64_t(bmode.data.size()) == bmode.geometry.voxel_count(),
            "the B-mode volume holds " << bmode.data.size() << " values for "
                                       << bmode.geometry.voxel_count() << " voxels");
  const ProbeFrame frame = make_frame(pose);

  RayGrid grid;
  grid.step = o.grid_step_mm;
  grid.dstep = o.depth_step_mm;
  grid.d0 = o.min_depth_mm;
  grid.nu = int(std::floor(o.aperture_width_mm / o.grid_step_mm + 1e-9)) + 1;
  grid.nv = int(std::floor(o.aperture_elevation_mm / o.grid_step_mm + 1e-9)) + 1;
  grid.nd = int(std::floor((o.max_depth_mm - o.min_depth_mm) / o.depth_step_mm + 1e-9)) + 1;

  FootprintResult r;
  r.rays = grid.rays();
  if (bmode.empty()) return no_band(r, "the B-mode volume is empty");

  const std::vector<float> f =
      filtered_samples(bmode, frame, grid, o.smoothing_sigma_mm, r.missing_samples);

  std::vector<float> finite;
  finite.reserve(f.size());
  for (float v : f)
    if (std::isfinite(v)) finite.push_back(v);
  if (finite.empty())
    return no_band(r, "no image data under the probe face (outside the volume or NaN)");

  std::string why;
  const double threshold = choose_threshold(finite, o, r, why);
  if (!std::isfinite(threshold)) return no_band(r, why);
  r.threshold = threshold;
  why = contrast_check(finite, threshold, o.min_contrast, r.contrast);
  if (!why.empty()) return no_band(r, why);

  // Band depth on each ray, then the largest depth-continuous patch.
  std::vector<double> depth(std::size_t(grid.rays()), std::numeric_limits<double>::quiet_NaN());
  for (int ray = 0; ray < grid.rays(); ++ray) {
    depth[std::size_t(ray)] =
        band_depth(&f[std::size_t(ray) * std::size_t(grid.nd)], grid, threshold, o);
    if (std::isfinite(depth[std::size_t(ray)])) ++r.rays_with_band;
  }
  const std::vector<int> patch = largest_patch(depth, grid, o.max_depth_jump_mm, r.patches);
  r.patch_rays = int(patch.size());
  r.patch_area_mm2 = double(patch.size()) * grid.step * grid.step;
  if (!patch.empty()) {
    const auto [i_lo, i_hi] = std::minmax_element(
        patch.begin(), patch.end(), [&](int a, int b) { return a % grid.nu < b % grid.nu; });
    r.patch_width_mm = grid.x(*i_hi % grid.nu) - grid.x(*i_lo % grid.nu);
    const auto [j_lo, j_hi] = std::minmax_element(
        patch.begin(), patch.end(), [&](int a, int b) { return a / grid.nu < b / grid.nu; });
    r.patch_elevation_mm = grid.y(*j_hi / grid.nu) - grid.y(*j_lo / grid.nu);
  }
  if (patch.empty() || r.patch_area_mm2 < o.min_patch_area_mm2) {
    std::ostringstream s;
    s << "the largest patch covers " << r.patch_area_mm2 << " mm² of the face, below "
      << o.min_patch_area_mm2 << " mm²";
    return no_band(r, s.str());
  }
  std::vector<char> in_patch(std::size_t(grid.rays()), 0);
  for (int ray : patch) in_patch[std::size_t(ray)] = 1;
  const auto nodes = lattice_nodes(patch, in_patch, grid, o.sample_spacing_mm);
  r.lattice_nodes = int(nodes.size());

  std::vector<Vector3d> points;
  std::vector<Vector3d> normals;
  fit_nodes(nodes, grid, depth, in_patch, frame, o, points, normals, r.nodes_skipped);
  if (points.empty())
    return no_band(r, "no lattice node of the patch has enough points for a surface fit");

  r.points.resize(Eigen::Index(points.size()), 3);
  r.normals.resize(Eigen::Index(points.size()), 3);
  for (std::size_t n = 0; n < points.size(); ++n) {
    r.points.row(Eigen::Index(n)) = points[n].transpose();
    r.normals.row(Eigen::Index(n)) = normals[n].transpose();
  }
  r.status = FootprintStatus::OK;
  std::ostringstream s;
  s << points.size() << " footprint points over a " << r.patch_area_mm2 << " mm² contact patch ("
    << r.threshold_rule << " threshold " << threshold << ", contrast " << r.contrast << ")";
  r.message = s.str();
  logger().info("footprint: {}", r.message);
  return r;
}

}  // namespace brainshift::imaging
