#include "imaging/footprint/beam_direction.hpp"

#include "core/error.hpp"
#include "core/logger.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <sstream>
#include <vector>

namespace brainshift::imaging {
namespace {

constexpr double kPi = 3.14159265358979323846;

/// Swept voxel centres (a regular subsample, centred on their mean) and the mean.
struct Cloud {
  std::vector<Vector3d> points;
  Vector3d mean = Vector3d::Zero();
  double voxel_mm3 = 0.0;  ///< volume each point stands for
  std::int64_t swept = 0;
};

Cloud swept_cloud(const VolumeF& image, int max_points) {
  const auto& g = image.geometry;
  Cloud c;
  for (const float v : image.data) c.swept += (std::isfinite(v) && v != 0.0F) ? 1 : 0;
  if (c.swept == 0) return c;
  const std::int64_t stride = std::max<std::int64_t>(1, c.swept / max_points);
  std::int64_t seen = 0;
  for (int k = 0; k < g.size[2]; ++k)
    for (int j = 0; j < g.size[1]; ++j)
      for (int i = 0; i < g.size[0]; ++i) {
        const float v = image.at(i, j, k);
        if (!(std::isfinite(v) && v != 0.0F)) continue;
        if (seen++ % stride == 0) c.points.push_back(g.index_to_world(Vector3d(i, j, k)));
      }
  for (const auto& p : c.points) c.mean += p;
  c.mean /= double(c.points.size());
  for (auto& p : c.points) p -= c.mean;
  c.voxel_mm3 = double(c.swept) * g.spacing.prod() / double(c.points.size());
  return c;
}

/// Quantile q ∈ [0, 1] of `values` (reordered).
double quantile(std::vector<double>& values, double q) {
  const auto n = std::size_t(q * double(values.size() - 1) + 0.5);
  std::nth_element(values.begin(), values.begin() + long(n), values.end());
  return values[n];
}

/// Weighted least-squares line y = a + b t.
struct LineFit {
  double sw = 0, st = 0, stt = 0, sy = 0, sty = 0;
  void add(double t, double y, double w = 1.0) {
    sw += w;
    st += w * t;
    stt += w * t * t;
    sy += w * y;
    sty += w * t * y;
  }
  [[nodiscard]] std::array<double, 2> solve() const {
    const double den = sw * stt - st * st;
    if (!(std::abs(den) > 1e-12)) return {sw > 0 ? sy / sw : 0.0, 0.0};
    const double b = (sw * sty - st * sy) / den;
    return {(sy - b * st) / sw, b};
  }
};

/// The fan score of direction d: relative linear growth of the cross-section minus twice the
/// centroid drift (both over the slabs holding at least a quarter of the largest one).
double fan_score(const Cloud& c, const Vector3d& d) {
  const Vector3d e1 = d.unitOrthogonal();
  const Vector3d e2 = d.cross(e1);
  double lo = 1e300, hi = -1e300;
  for (const auto& p : c.points) {
    lo = std::min(lo, d.dot(p));
    hi = std::max(hi, d.dot(p));
  }
  if (!(hi - lo > 1.0)) return -1e300;  // (nearly) flat along d: a plane of voxels, no fan
  const int nb = std::max(4, int((hi - lo) / 2.0));
  std::vector<double> n(std::size_t(nb), 0.0), c1(std::size_t(nb), 0.0), c2(std::size_t(nb), 0.0);
  for (const auto& p : c.points) {
    const auto b = std::size_t(std::clamp(int((d.dot(p) - lo) / (hi - lo) * nb), 0, nb - 1));
    n[b] += 1.0;
    c1[b] += e1.dot(p);
    c2[b] += e2.dot(p);
  }
  const double most = *std::max_element(n.begin(), n.end());
  LineFit f1, f2, fa;
  for (int b = 0; b < nb; ++b) {
    const auto s = std::size_t(b);
    if (n[s] < 0.25 * most) continue;
    const double t = lo + (b + 0.5) * (hi - lo) / nb;
    f1.add(t, c1[s] / n[s], n[s]);
    f2.add(t, c2[s] / n[s], n[s]);
    fa.add(t, n[s], n[s]);
  }
  const double growth = fa.solve()[1] * (hi - lo) / most;
  const double drift = std::hypot(f1.solve()[1], f2.solve()[1]);
  return growth - 2.0 * drift;
}

/// A frustum along d: four straight edges (lateral low/high, elevation low/high) over depth t
/// measured from `lo`, in the transverse axes (u, v).
struct Frustum {
  Vector3d d, u, v;
  double lo = 0.0, hi = 0.0;
  std::array<std::array<double, 2>, 4> edge{};  // (a, b): a + b t
  double iou = -1.0;
  [[nodiscard]] double at(int e, double t) const {
    return edge[std::size_t(e)][0] + edge[std::size_t(e)][1] * t;
  }
  [[nodiscard]] double width(double t) const { return std::max(0.0, at(1, t) - at(0, t)); }
  [[nodiscard]] double height(double t) const { return std::max(0.0, at(3, t) - at(2, t)); }
};

Frustum fit_frustum(const Cloud& c, const Vector3d& d, double slab) {
  std::vector<double> t(c.points.size());
  for (std::size_t p = 0; p < t.size(); ++p) t[p] = d.dot(c.points[p]);
  std::vector<double> sorted = t;
  const double lo = quantile(sorted, 0.002);
  const double hi = quantile(sorted, 0.998);
  const int nb = std::max(2, int(std::ceil((hi - lo) / slab)));
  const Vector3d a = d.unitOrthogonal();
  const Vector3d b = d.cross(a);
  Frustum best;
  std::vector<std::vector<double>> us(static_cast<std::size_t>(nb));
  std::vector<std::vector<double>> vs(static_cast<std::size_t>(nb));
  for (int step = 0; step < 18; ++step) {  // transverse axes turned by 5° steps over 90°
    const double psi = step * kPi / 36.0;
    Frustum f;
    f.d = d;
    f.u = std::cos(psi) * a + std::sin(psi) * b;
    f.v = d.cross(f.u);
    f.lo = lo;
    f.hi = hi;
    for (auto& s : us) s.clear();
    for (auto& s : vs) s.clear();
    for (std::size_t p = 0; p < t.size(); ++p) {
      const auto s = std::size_t(std::clamp(int((t[p] - lo) / slab), 0, nb - 1));
      us[s].push_back(f.u.dot(c.points[p]));
      vs[s].push_back(f.v.dot(c.points[p]));
    }
    std::size_t most = 0;
    for (const auto& s : us) most = std::max(most, s.size());
    std::array<LineFit, 4> fits;
    for (int s = 0; s < nb; ++s) {
      auto& su = us[std::size_t(s)];
      auto& sv = vs[std::size_t(s)];
      if (double(su.size()) < 0.3 * double(most) || su.size() < 5) continue;
      const double ts = (s + 0.5) * slab;
      fits[0].add(ts, quantile(su, 0.02));
      fits[1].add(ts, quantile(su, 0.98));
      fits[2].add(ts, quantile(sv, 0.02));
      fits[3].add(ts, quantile(sv, 0.98));
    }
    for (int e = 0; e < 4; ++e) f.edge[std::size_t(e)] = fits[std::size_t(e)].solve();
    double model = 0.0;
    for (int s = 0; s < nb; ++s)
      model += f.width((s + 0.5) * slab) * f.height((s + 0.5) * slab) * slab;
    std::size_t inside = 0;
    for (std::size_t p = 0; p < t.size(); ++p) {
      const double ts = t[p] - lo;
      const double pu = f.u.dot(c.points[p]);
      const double pv = f.v.dot(c.points[p]);
      if (ts >= 0.0 && ts <= hi - lo && pu >= f.at(0, ts) && pu <= f.at(1, ts) &&
          pv >= f.at(2, ts) && pv <= f.at(3, ts))
        ++inside;
    }
    const double region = double(c.points.size()) * c.voxel_mm3;
    const double common = double(inside) * c.voxel_mm3;
    f.iou = common / std::max(region + model - common, 1e-300);
    if (f.iou > best.iou) best = f;
  }
  return best;
}

/// Local search on the fan fit around f.d (steps of 6°, halved down to 0.75°).
Frustum refine(const Cloud& c, Frustum f, double slab) {
  for (double step = 6.0; step > 0.7; step /= 2.0) {
    for (bool improved = true; improved;) {
      improved = false;
      const Vector3d a = f.d.unitOrthogonal();
      const Vector3d b = f.d.cross(a);
      for (const Vector3d& dir : {a, Vector3d(-a), b, Vector3d(-b)}) {
        const Frustum g =
            fit_frustum(c, (f.d + std::tan(step * kPi / 180.0) * dir).normalized(), slab);
        if (g.iou > f.iou + 1e-4) {
          f = g;
          improved = true;
        }
      }
    }
  }
  return f;
}

Vector3d fibonacci(int s, int n) {
  const double z = 1.0 - 2.0 * (s + 0.5) / n;
  const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
  const double phi = s * 2.399963229728653;  // golden angle
  return {r * std::cos(phi), r * std::sin(phi), z};
}

}  // namespace

std::string BeamOptions::validate() const {
  std::ostringstream e;
  if (max_points < 1000) e << "max_points = " << max_points << " must be >= 1000; ";
  if (directions < 100) e << "directions = " << directions << " must be >= 100; ";
  if (!(std::isfinite(slab_mm) && slab_mm > 0.0)) e << "slab_mm = " << slab_mm << " must be > 0; ";
  std::string s = e.str();
  if (s.size() >= 2) s.resize(s.size() - 2);
  return s;
}

BeamEstimate estimate_beam(const VolumeF& bmode, const std::optional<Vector3d>& given,
                           const BeamOptions& o) {
  const std::string invalid = o.validate();
  BS_VERIFY(invalid.empty(), "beam options: " << invalid);
  BS_VERIFY(bmode.components == 1,
            "the B-mode volume has " << bmode.components << " components, expected 1");
  BS_VERIFY(std::int64_t(bmode.data.size()) == bmode.geometry.voxel_count(),
            "the B-mode volume holds " << bmode.data.size() << " values for "
                                       << bmode.geometry.voxel_count() << " voxels");
  if (given)
    BS_VERIFY(given->allFinite() && given->norm() > 1e-9,
              "the probe direction must be a finite non-zero vector, got " << given->transpose());
  const Cloud c = swept_cloud(bmode, o.max_points);
  BS_VERIFY(
      c.swept >= 100,
      "no swept region: " << c.swept << " voxels are finite and non-zero (at least 100 needed)");

  Frustum f;
  if (given) {
    f = fit_frustum(c, given->normalized(), o.slab_mm);
  } else {
    std::vector<Vector3d> dirs(std::size_t(o.directions));
    std::vector<double> score(dirs.size());
    for (std::size_t s = 0; s < dirs.size(); ++s) {
      dirs[s] = fibonacci(int(s), o.directions);
      score[s] = fan_score(c, dirs[s]);
    }
    const double neighbourhood = std::cos(15.0 * kPi / 180.0);
    const auto top = std::size_t(std::max_element(score.begin(), score.end()) - score.begin());
    for (std::size_t s = 0; s < dirs.size(); ++s) {
      if (s != top && score[s] < 0.1) continue;
      bool local_max = true;
      for (std::size_t q = 0; q < dirs.size() && local_max; ++q)
        local_max = q == s || dirs[q].dot(dirs[s]) <= neighbourhood || score[q] <= score[s];
      if (!local_max) continue;
      const Frustum g = fit_frustum(c, dirs[s], o.slab_mm);
      if (g.iou > f.iou) f = g;
    }
    f = refine(c, f, o.slab_mm);
  }
  // Point from the narrow end to the wide end (unless given).
  const double span = f.hi - f.lo;
  double near_area = f.width(0.0) * f.height(0.0);
  double far_area = f.width(span) * f.height(span);
  if (!given && far_area < near_area) {
    Frustum flipped = f;
    flipped.d = -f.d;
    flipped.lo = -f.hi;
    flipped.hi = -f.lo;
    flipped.u = -f.u;  // keeps (u, v, d) right-handed: v = d × u unchanged
    flipped.v = flipped.d.cross(flipped.u);
    // Edges in the new depth t' = span − t; u' = −u negates and swaps the lateral pair.
    const auto flip_edge = [&](int e, double sign) {
      return std::array<double, 2>{sign * f.at(e, span), -sign * f.edge[std::size_t(e)][1]};
    };
    flipped.edge[0] = flip_edge(1, -1.0);
    flipped.edge[1] = flip_edge(0, -1.0);
    flipped.edge[2] = flip_edge(2, 1.0);
    flipped.edge[3] = flip_edge(3, 1.0);
    f = flipped;
    std::swap(near_area, far_area);
  }
  BeamEstimate r;
  r.given = given.has_value();
  r.swept_voxels = c.swept;
  r.direction = f.d;
  r.depth_mm = span;
  r.fan_fit = std::max(0.0, f.iou);
  // Lateral: the transverse axis of most widening.
  const double grow_u = f.edge[1][1] - f.edge[0][1];
  const double grow_v = f.edge[3][1] - f.edge[2][1];
  const bool swap = grow_v > grow_u;
  r.lateral = swap ? f.v : f.u;
  r.elevation = r.direction.cross(r.lateral);
  r.near_width_mm = swap ? f.height(0.0) : f.width(0.0);
  r.near_elevation_mm = swap ? f.width(0.0) : f.height(0.0);
  r.far_width_mm = swap ? f.height(span) : f.width(span);
  r.far_elevation_mm = swap ? f.width(span) : f.height(span);
  r.face_centre = c.mean + f.lo * f.d + 0.5 * (f.at(0, 0.0) + f.at(1, 0.0)) * f.u +
                  0.5 * (f.at(2, 0.0) + f.at(3, 0.0)) * f.v;
  logger().info(
      "beam: direction ({:.3f}, {:.3f}, {:.3f}) {}, fan fit {:.3f}, near end {:.1f} x {:.1f} mm",
      r.direction.x(), r.direction.y(), r.direction.z(), r.given ? "given" : "estimated", r.fan_fit,
      r.near_width_mm, r.near_elevation_mm);
  return r;
}

}  // namespace brainshift::imaging
