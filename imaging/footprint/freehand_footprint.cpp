#include "imaging/footprint/freehand_footprint.hpp"

#include "core/error.hpp"
#include "core/logger.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

namespace brainshift::imaging {
namespace {

/// True when the voxel nearest to p is inside the grid, finite and non-zero (swept).
bool swept_at(const VolumeF& image, const Vector3d& p) {
  const Vector3d c = image.geometry.world_to_index(p);
  const int i = int(std::lround(c.x()));
  const int j = int(std::lround(c.y()));
  const int k = int(std::lround(c.z()));
  if (!image.geometry.contains_index(i, j, k)) return false;
  const float v = image.at(i, j, k);
  return std::isfinite(v) && v != 0.0F;
}

/// How far p lies below the first swept voxel met going back along -d (0.25 mm steps, up to
/// `reach`); `reach` when the region extends further.
double depth_below_edge(const VolumeF& image, const Vector3d& p, const Vector3d& d, double reach) {
  constexpr double step = 0.25;
  double s = 0.0;
  while (s < reach && swept_at(image, p - (s + step) * d)) s += step;
  return s;
}

/// Mean of the swept voxels (trilinear-free: nearest voxel) at p + s·d + a·u + b·v over a disc
/// of `radius` (1 mm steps) and s in [s0, s1] (0.5 mm steps); NaN when none is swept.
double disc_mean(const VolumeF& image, const Vector3d& p, const Vector3d& d, const Vector3d& u,
                 const Vector3d& v, double radius, double s0, double s1) {
  double sum = 0.0;
  int n = 0;
  const int reach = int(std::floor(radius));
  for (double s = s0; s <= s1 + 1e-9; s += 0.5)
    for (int a = -reach; a <= reach; ++a)
      for (int b = -reach; b <= reach; ++b) {
        if (a * a + b * b > radius * radius) continue;
        const Vector3d q = p + s * d + a * u + b * v;
        const Vector3d c = image.geometry.world_to_index(q);
        const int i = int(std::lround(c.x())), j = int(std::lround(c.y())),
                  k = int(std::lround(c.z()));
        if (!image.geometry.contains_index(i, j, k)) continue;
        const float x = image.at(i, j, k);
        if (!(std::isfinite(x) && x != 0.0F)) continue;
        sum += x;
        ++n;
      }
  return n > 0 ? sum / n : std::numeric_limits<double>::quiet_NaN();
}

FootprintResult no_band_result(FootprintResult r, const std::string& why) {
  r.status = FootprintStatus::NO_BAND;
  r.message = "no contact band found: " + why;
  r.points.resize(0, 3);
  r.normals.resize(0, 3);
  return r;
}

std::string fixed(double value, int digits = 1) {
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(digits);
  s << value;
  return s.str();
}

}  // namespace

std::string FreehandFootprintOptions::validate() const {
  std::ostringstream e;
  const auto positive = [&](double value, const char* name) {
    if (!(std::isfinite(value) && value > 0.0)) e << name << " = " << value << " must be > 0; ";
  };
  positive(margin_mm, "margin_mm");
  positive(search_depth_mm, "search_depth_mm");
  positive(min_slab_contrast, "min_slab_contrast");
  positive(min_band_contrast, "min_band_contrast");
  positive(sample_spacing_mm, "sample_spacing_mm");
  if (!(std::isfinite(smoothing_sigma_mm) && smoothing_sigma_mm >= 0.0))
    e << "smoothing_sigma_mm = " << smoothing_sigma_mm << " must be >= 0; ";
  if (!(std::isfinite(min_width_mm) && min_width_mm >= 0.0))
    e << "min_width_mm = " << min_width_mm << " must be >= 0; ";
  if (!(std::isfinite(max_face_distance_mm) && max_face_distance_mm >= 0.0))
    e << "max_face_distance_mm = " << max_face_distance_mm << " must be >= 0; ";
  if (!(min_fan_fit >= 0.0 && min_fan_fit <= 1.0))
    e << "min_fan_fit = " << min_fan_fit << " must be in [0, 1]; ";
  const std::string beam_error = beam.validate();
  if (!beam_error.empty()) e << beam_error << "; ";
  std::string s = e.str();
  if (s.size() >= 2) s.resize(s.size() - 2);
  return s;
}

FreehandFootprint extract_freehand_footprint(const VolumeF& bmode,
                                             const std::optional<Vector3d>& direction,
                                             const FreehandFootprintOptions& o) {
  const std::string invalid = o.validate();
  BS_VERIFY(invalid.empty(), "freehand footprint options: " << invalid);
  FreehandFootprint r;
  r.beam = estimate_beam(bmode, direction, o.beam);
  const BeamEstimate& b = r.beam;

  // Outside the swept region is missing data, not a dark echo.
  VolumeF image = bmode;
  for (float& v : image.data)
    if (v == 0.0F) v = std::numeric_limits<float>::quiet_NaN();

  ProbePose pose;
  pose.axis = b.direction;
  pose.lateral = b.lateral;
  pose.face_centre = b.face_centre - o.margin_mm * b.direction;
  FootprintOptions f;
  // The rays cover the narrow end (at least 2 mm each way, so that a pointed end still gets
  // rays; a footprint that small is flagged below).
  f.aperture_width_mm = std::max(2.0, b.near_width_mm);
  f.aperture_elevation_mm = std::max(2.0, b.near_elevation_mm);
  f.min_depth_mm = 0.0;
  f.max_depth_mm = o.margin_mm + o.search_depth_mm;
  f.smoothing_sigma_mm = o.smoothing_sigma_mm;
  f.min_contrast = o.min_slab_contrast;
  f.leading_missing_is_outside = true;
  f.sample_spacing_mm = o.sample_spacing_mm;
  r.footprint = extract_footprint(image, pose, f);
  if (!b.given && b.fan_fit < o.min_fan_fit)
    r.warnings.push_back("the swept region fits a fan poorly (" + fixed(b.fan_fit, 2) + " < " +
                         fixed(o.min_fan_fit, 2) +
                         "): the estimated beam direction may be wrong; give the probe direction");
  if (b.given && b.far_width_mm * b.far_elevation_mm < b.near_width_mm * b.near_elevation_mm)
    r.warnings.push_back(
        "the swept region narrows along the given probe direction (" +
        fixed(b.near_width_mm * b.near_elevation_mm, 0) + " to " +
        fixed(b.far_width_mm * b.far_elevation_mm, 0) +
        " mm2 across): is it reversed? It must point from the probe into the tissue");
  if (r.footprint.status != FootprintStatus::OK) {
    for (const auto& w : r.warnings) logger().warn("footprint: {}", w);
    return r;
  }

  // The patch's smaller extent is the probe face's width; the larger one the sweep's length.
  r.width_mm = std::min(r.footprint.patch_width_mm, r.footprint.patch_elevation_mm);
  r.elevation_mm = std::max(r.footprint.patch_width_mm, r.footprint.patch_elevation_mm);
  std::vector<double> distance, contrast;
  for (Eigen::Index p = 0; p < r.footprint.points.rows(); ++p) {
    const Vector3d x = r.footprint.points.row(p).transpose();
    const Vector3d n = r.footprint.normals.row(p).transpose();
    const Vector3d u = (b.lateral - b.lateral.dot(n) * n).normalized();
    const Vector3d v = n.cross(u);
    distance.push_back(depth_below_edge(bmode, x, b.direction, 50.0));
    const double band = disc_mean(bmode, x, n, u, v, 3.0, -1.0, 1.0);
    const double tissue = disc_mean(bmode, x, n, u, v, 3.0, 3.0, 15.0);
    contrast.push_back(std::isfinite(band / tissue) ? band / tissue : 0.0);
  }
  // The band contrast: median over the points of the band's echo over the tissue's below.
  std::vector<double> sorted = contrast;
  std::nth_element(sorted.begin(), sorted.begin() + long(sorted.size() / 2), sorted.end());
  const double median_contrast = sorted[sorted.size() / 2];
  r.footprint.contrast = median_contrast;
  if (median_contrast < o.min_band_contrast) {
    r.footprint =
        no_band_result(r.footprint, "band contrast " + fixed(median_contrast, 2) +
                                        " (band echo over the tissue 3-15 mm below) is below " +
                                        fixed(o.min_band_contrast, 2));
    return r;
  }
  // Points far below the edge of the swept region are not where the probe touched.
  MatrixX3d points(r.footprint.points.rows(), 3), normals(r.footprint.points.rows(), 3);
  Eigen::Index kept = 0;
  double deepest = 0.0;
  for (Eigen::Index p = 0; p < r.footprint.points.rows(); ++p) {
    deepest = std::max(deepest, distance[std::size_t(p)]);
    if (distance[std::size_t(p)] > o.max_face_distance_mm) continue;
    points.row(kept) = r.footprint.points.row(p);
    normals.row(kept) = r.footprint.normals.row(p);
    r.face_distance_mm.push_back(distance[std::size_t(p)]);
    r.band_contrast.push_back(contrast[std::size_t(p)]);
    ++kept;
  }
  if (kept == 0) {
    r.footprint = no_band_result(
        r.footprint, "every bright echo found lies more than " + fixed(o.max_face_distance_mm) +
                         " mm (up to " + fixed(deepest) +
                         " mm) below the near edge of the swept region: not a contact band");
    return r;
  }
  if (kept < r.footprint.points.rows())
    r.warnings.push_back(std::to_string(r.footprint.points.rows() - kept) +
                         " footprint point(s) dropped: up to " + fixed(deepest) +
                         " mm below the near edge of the swept region (more than " +
                         fixed(o.max_face_distance_mm) + " mm)");
  r.footprint.points = points.topRows(kept);
  r.footprint.normals = normals.topRows(kept);
  if (r.width_mm < o.min_width_mm)
    r.warnings.push_back("small footprint: the contact patch is " + fixed(r.width_mm) +
                         " mm wide (a probe face is 10-40 mm)");
  if (kept < 3)
    r.warnings.push_back("small footprint: only " + std::to_string(kept) + " footprint point(s)");
  std::ostringstream m;
  m << kept << " footprint points over a " << fixed(r.width_mm) << " x " << fixed(r.elevation_mm)
    << " mm contact patch (band contrast " << fixed(median_contrast, 2) << ", beam "
    << (b.given ? "given" : "estimated") << ")";
  r.footprint.message = m.str();
  for (const auto& w : r.warnings) logger().warn("footprint: {}", w);
  return r;
}

}  // namespace brainshift::imaging
