#include "data_synth/images/probe.hpp"

#include "core/error.hpp"

#include <cmath>
#include <numbers>
#include <sstream>

namespace brainshift::data_synth {

namespace {
double radians(double deg) { return deg * std::numbers::pi / 180.0; }

Matrix3d rotation(const Vector3d& deg) {
  return (Eigen::AngleAxisd(radians(deg.z()), Vector3d::UnitZ()) *
          Eigen::AngleAxisd(radians(deg.y()), Vector3d::UnitY()) *
          Eigen::AngleAxisd(radians(deg.x()), Vector3d::UnitX()))
      .toRotationMatrix();
}
}  // namespace

std::string ProbeOptions::validate() const {
  std::ostringstream s;
  if (!(half_angle_deg > 0.0 && half_angle_deg < 80.0))
    s << "half_angle_deg must lie in (0, 80), got " << half_angle_deg;
  else if (!(depth > 0.0) || !(footprint_radius > 0.0) || !(spacing > 0.0))
    s << "depth, footprint_radius and spacing must be > 0 mm, got " << depth << ", "
      << footprint_radius << ", " << spacing;
  return s.str();
}

bool Probe::in_field_of_view(const Vector3d& p) const {
  const Vector3d q = frame.transpose() * (p - face_centre);
  if (q.z() < 0.0 || q.z() > options.depth) return false;
  const double r = options.footprint_radius + q.z() * std::tan(radians(options.half_angle_deg));
  return q.head<2>().squaredNorm() <= r * r;
}

imaging::ImageGeometry Probe::grid() const {
  const double h = options.spacing;
  const double w =
      options.footprint_radius + options.depth * std::tan(radians(options.half_angle_deg));
  const int nl = int(std::ceil(2.0 * w / h)) + 1;
  const int na = int(std::ceil(options.depth / h)) + 1;
  imaging::ImageGeometry g;
  g.size = {nl, nl, na};
  g.spacing = Vector3d::Constant(h);
  g.direction = frame;
  g.origin = face_centre + frame * Vector3d(-0.5 * (nl - 1) * h, -0.5 * (nl - 1) * h, 0.0);
  return g;
}

Probe make_probe(const Vector3d& face_centre, const Vector3d& axis, const ProbeOptions& options) {
  const std::string bad = options.validate();
  BS_VERIFY(bad.empty(), "invalid probe options: " << bad);
  BS_VERIFY(axis.norm() > 0.0 && axis.allFinite() && face_centre.allFinite(),
            "probe axis must be finite and non-zero, got (" << axis.transpose() << ")");
  Probe probe;
  probe.face_centre = face_centre;
  probe.options = options;
  const Vector3d z = axis.normalized();
  // Lateral 1: world R projected off the axis (A when the axis is along R).
  Vector3d x = Vector3d::UnitX() - Vector3d::UnitX().dot(z) * z;
  if (x.norm() < 1e-3) x = Vector3d::UnitY() - Vector3d::UnitY().dot(z) * z;
  x.normalize();
  probe.frame.col(0) = x;
  probe.frame.col(1) = z.cross(x);
  probe.frame.col(2) = z;
  return probe;
}

Vector3d TrackingError::apply(const Vector3d& p, const Vector3d& pivot) const {
  return rotation(rotation_deg) * (p - pivot) + pivot + translation;
}

imaging::ImageGeometry with_tracking_error(const imaging::ImageGeometry& grid, const Probe& probe,
                                           const TrackingError& error) {
  return with_tracking_error(grid, probe.face_centre, error);
}

imaging::ImageGeometry with_tracking_error(const imaging::ImageGeometry& grid,
                                           const Vector3d& pivot, const TrackingError& error) {
  imaging::ImageGeometry g = grid;
  g.origin = error.apply(grid.origin, pivot);
  g.direction = rotation(error.rotation_deg) * grid.direction;
  return g;
}

}  // namespace brainshift::data_synth
