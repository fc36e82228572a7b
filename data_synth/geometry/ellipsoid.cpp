#include "data_synth/geometry/ellipsoid.hpp"

#include <cmath>
#include <numbers>

namespace brainshift::data_synth {

double Ellipsoid::volume() const { return 4.0 / 3.0 * std::numbers::pi * semi_axes.prod(); }

Vector3d Ellipsoid::normal(const Vector3d& x) const {
  const Vector3d g = (x - centre).cwiseQuotient(semi_axes.cwiseProduct(semi_axes));
  const double n = g.norm();
  return n > 0.0 ? Vector3d(g / n) : Vector3d::UnitZ();
}

Vector3d Ellipsoid::closest_point(const Vector3d& x) const {
  const Vector3d p = x - centre;
  const Vector3d a2 = semi_axes.cwiseProduct(semi_axes);
  // g(t) = Σ (a_i p_i / (a_i² + t))² − 1 is convex and decreasing on (−min a², ∞).
  auto g = [&](double t) {
    return (semi_axes.cwiseProduct(p).array() / (a2.array() + t)).square().sum() - 1.0;
  };
  auto dg = [&](double t) {
    return -2.0 * (a2.cwiseProduct(p.cwiseProduct(p)).array() / (a2.array() + t).cube()).sum();
  };
  const double g0 = g(0.0);
  if (g0 == 0.0) return x;
  double lo = 0.0, hi = 0.0;
  if (g0 > 0.0) {  // outside: root in (0, max a · |p|]
    hi = semi_axes.maxCoeff() * p.norm();
  } else {  // inside: root in (−min a², 0)
    lo = -a2.minCoeff() * (1.0 - 1e-12);
  }
  double t = 0.0;
  for (int it = 0; it < 100; ++it) {
    const double gt = g(t);
    if (gt > 0.0)
      lo = t;
    else
      hi = t;
    const double d = dg(t);
    double next = (d < 0.0) ? t - gt / d : 0.5 * (lo + hi);
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
    if (std::abs(next - t) <= 1e-14 * (1.0 + std::abs(t))) {
      t = next;
      break;
    }
    t = next;
  }
  Vector3d q = a2.cwiseProduct(p).array() / (a2.array() + t);
  const double level_q = q.cwiseQuotient(semi_axes).squaredNorm();
  if (!(std::abs(level_q - 1.0) < 1e-8)) {
    // Degenerate inside case: radial projection (never worse than a point off the surface).
    q = p / std::sqrt(p.cwiseQuotient(semi_axes).squaredNorm());
  }
  return centre + q;
}

}  // namespace brainshift::data_synth
