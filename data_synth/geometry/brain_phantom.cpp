#include "data_synth/geometry/brain_phantom.hpp"

#include "core/error.hpp"

#include <cmath>
#include <numbers>
#include <sstream>

namespace brainshift::data_synth {
namespace {

bool all_finite(const Vector3d& v) { return v.allFinite(); }

}  // namespace

std::string PhantomGeometry::validate() const {
  std::ostringstream s;
  if (!all_finite(centre) || !all_finite(tumour_offset) || !all_finite(ventricle_offset) ||
      !all_finite(craniotomy_direction))
    s << "phantom positions must be finite";
  else if (!((semi_axes.array() > 0).all() && semi_axes.allFinite()))
    s << "brain semi-axes must be positive, got " << semi_axes.transpose();
  else if (!(base_depth > 0.0 && base_depth <= 1.0))
    s << "base_depth must be in (0, 1], got " << base_depth;
  else if (!(tumour_radius > 0.0))
    s << "tumour_radius must be positive, got " << tumour_radius << " mm";
  else if (!inside_brain(tumour_centre()))
    s << "tumour centre " << tumour_centre().transpose() << " is outside the brain";
  else if (!(ventricle_scale >= 0.0) || !((ventricle_semi_axes.array() > 0).all()))
    s << "ventricle scale must be >= 0 and semi-axes positive";
  else if (!(craniotomy_direction.norm() > 0.0))
    s << "craniotomy_direction must be non-zero";
  else if (!(craniotomy_radius > 0.0))
    s << "craniotomy_radius must be positive, got " << craniotomy_radius << " mm";
  else if (!(skull_gap >= 0.0))
    s << "skull_gap must be >= 0, got " << skull_gap << " mm";
  return s.str();
}

Ellipsoid PhantomGeometry::skull() const {
  return {centre, semi_axes + Vector3d::Constant(skull_gap)};
}

double PhantomGeometry::base_level() const { return centre.z() - base_depth * semi_axes.z(); }

Ellipsoid PhantomGeometry::ventricle(int side) const {
  BS_VERIFY(side == 0 || side == 1, "ventricle side must be 0 (left) or 1 (right), got " << side);
  const double sign = side == 0 ? -1.0 : 1.0;
  return {centre + ventricle_offset + Vector3d(sign * 0.5 * ventricle_spacing, 0.0, 0.0),
          ventricle_semi_axes * ventricle_scale};
}

namespace {
/// Point where the ray centre + s·d meets the ellipsoid with the given semi-axes.
Vector3d ray_hit(const Vector3d& centre, const Vector3d& semi_axes, const Vector3d& d) {
  const Vector3d u = d.normalized();
  return centre + u / u.cwiseQuotient(semi_axes).norm();
}
}  // namespace

Vector3d PhantomGeometry::craniotomy_centre_on_brain() const {
  return ray_hit(centre, semi_axes, craniotomy_direction);
}

Vector3d PhantomGeometry::craniotomy_centre_on_skull() const {
  return ray_hit(centre, skull().semi_axes, craniotomy_direction);
}

bool PhantomGeometry::inside_brain(const Vector3d& x) const {
  return x.z() >= base_level() && brain_ellipsoid().contains(x);
}

imaging::Label PhantomGeometry::label_at(const Vector3d& x) const {
  if (!inside_brain(x)) return imaging::BACKGROUND;
  if ((x - tumour_centre()).squaredNorm() <= tumour_radius * tumour_radius) return imaging::TUMOUR;
  if (ventricle_scale > 0.0 && (ventricle(0).contains(x) || ventricle(1).contains(x)))
    return imaging::VENTRICLES;
  return imaging::BRAIN;
}

PhantomVolumes analytic_volumes(const PhantomGeometry& g) {
  const double d = g.base_depth;
  PhantomVolumes v;
  v.brain_total = std::numbers::pi * g.semi_axes.prod() * ((1.0 + d) - (1.0 + d * d * d) / 3.0);
  v.tumour = 4.0 / 3.0 * std::numbers::pi * std::pow(g.tumour_radius, 3);
  v.ventricles = g.ventricle_scale > 0.0 ? 2.0 * g.ventricle(0).volume() : 0.0;
  return v;
}

std::string PhantomImageOptions::validate() const {
  std::ostringstream s;
  if (!(spacing > 0.0))
    s << "image spacing must be positive, got " << spacing << " mm";
  else if (!(margin >= 0.0))
    s << "image margin must be >= 0, got " << margin << " mm";
  else if (!direction.allFinite() ||
           !(direction.transpose() * direction).isApprox(Matrix3d::Identity(), 1e-9) ||
           direction.determinant() < 0.0)
    s << "image direction must be a rotation (orthonormal, det +1)";
  return s.str();
}

imaging::LabelVolume make_label_volume(const PhantomGeometry& g, const PhantomImageOptions& o) {
  const std::string bad_geometry = g.validate();
  BS_VERIFY(bad_geometry.empty(), "invalid phantom geometry: " << bad_geometry);
  const std::string bad_options = o.validate();
  BS_VERIFY(bad_options.empty(), "invalid phantom image options: " << bad_options);
  // Skull bounding box corners, in the image axes (mm, relative to the world origin).
  const Vector3d lo_w = g.centre - g.skull().semi_axes, hi_w = g.centre + g.skull().semi_axes;
  Vector3d lo = Vector3d::Constant(1e300), hi = Vector3d::Constant(-1e300);
  for (int c = 0; c < 8; ++c) {
    const Vector3d p((c & 1) ? hi_w.x() : lo_w.x(), (c & 2) ? hi_w.y() : lo_w.y(),
                     (c & 4) ? hi_w.z() : lo_w.z());
    const Vector3d q = o.direction.transpose() * p;
    lo = lo.cwiseMin(q);
    hi = hi.cwiseMax(q);
  }
  imaging::ImageGeometry ig;
  ig.spacing = Vector3d::Constant(o.spacing);
  ig.direction = o.direction;
  const Vector3d first = ((lo.array() - o.margin) / o.spacing).floor();
  const Vector3d last = ((hi.array() + o.margin) / o.spacing).ceil();
  ig.size = (last - first).cast<int>() + Eigen::Vector3i::Ones();
  ig.origin = o.direction * (first * o.spacing);
  imaging::LabelVolume vol(ig, 1, imaging::BACKGROUND);
  for (int k = 0; k < ig.size[2]; ++k)
    for (int j = 0; j < ig.size[1]; ++j)
      for (int i = 0; i < ig.size[0]; ++i)
        vol.at(i, j, k) = g.label_at(ig.index_to_world(Vector3d(i, j, k)));
  return vol;
}

}  // namespace brainshift::data_synth
