#include "data_synth/geometry/distance_field.hpp"

#include "core/error.hpp"
#include "imaging/vessels/distance_transform.hpp"

#include <algorithm>
#include <cmath>

namespace brainshift::data_synth {
namespace {

/// `mask` copied into a grid grown by `pad` voxels on every side (same spacing and direction).
imaging::LabelVolume padded(const imaging::LabelVolume& mask, int pad) {
  imaging::ImageGeometry g = mask.geometry;
  g.size += Eigen::Vector3i::Constant(2 * pad);
  g.origin = mask.geometry.index_to_world(Vector3d::Constant(-pad));
  imaging::LabelVolume out(g, 1, 0);
  const Eigen::Vector3i& n = mask.geometry.size;
  for (int k = 0; k < n[2]; ++k)
    for (int j = 0; j < n[1]; ++j)
      for (int i = 0; i < n[0]; ++i)
        if (mask.at(i, j, k) != 0) out.at(i + pad, j + pad, k + pad) = 1;
  return out;
}

imaging::LabelVolume complement(const imaging::LabelVolume& m) {
  imaging::LabelVolume out(m.geometry, 1, 0);
  for (std::size_t v = 0; v < m.data.size(); ++v) out.data[v] = m.data[v] != 0 ? 0 : 1;
  return out;
}

int voxels(const imaging::ImageGeometry& g, double mm) {
  return int(std::ceil(mm / g.spacing.minCoeff()));
}

}  // namespace

DistanceField::DistanceField(imaging::VolumeF phi) : m_phi(std::move(phi)) {
  BS_VERIFY(m_phi.geometry.voxel_count() > 0 && m_phi.components == 1,
            "a distance field needs a non-empty one-component volume");
}

double DistanceField::value(const Vector3d& x) const {
  const imaging::ImageGeometry& g = m_phi.geometry;
  const Vector3d ijk = g.world_to_index(x);
  const Vector3d hi = (g.size - Eigen::Vector3i::Ones()).cast<double>();
  const Vector3d c = ijk.cwiseMax(Vector3d::Zero()).cwiseMin(hi);
  const double outside = (ijk - c).cwiseProduct(g.spacing).norm();
  const Eigen::Vector3i i0 = c.array()
                                 .floor()
                                 .cast<int>()
                                 .min((g.size - Eigen::Vector3i::Constant(2)).array().max(0))
                                 .matrix();
  const Vector3d f = c - i0.cast<double>();
  double v = 0.0;
  for (int corner = 0; corner < 8; ++corner) {
    const int dx = corner & 1, dy = (corner >> 1) & 1, dz = (corner >> 2) & 1;
    const int i = std::min(i0.x() + dx, g.size.x() - 1), j = std::min(i0.y() + dy, g.size.y() - 1),
              k = std::min(i0.z() + dz, g.size.z() - 1);
    const double w =
        (dx ? f.x() : 1.0 - f.x()) * (dy ? f.y() : 1.0 - f.y()) * (dz ? f.z() : 1.0 - f.z());
    v += w * double(m_phi.at(i, j, k));
  }
  return v + outside;
}

Vector3d DistanceField::gradient(const Vector3d& x) const {
  const double h = 0.5 * m_phi.geometry.spacing.minCoeff();
  Vector3d g;
  for (int a = 0; a < 3; ++a) {
    const Vector3d e = h * Vector3d::Unit(a);
    g[a] = (value(x + e) - value(x - e)) / (2.0 * h);
  }
  return g;
}

Vector3d DistanceField::normal(const Vector3d& x) const {
  const Vector3d g = gradient(x);
  return g.norm() > 1e-9 ? Vector3d(g.normalized()) : Vector3d::UnitZ();
}

Vector3d DistanceField::closest_point(const Vector3d& x, double level) const {
  Vector3d p = x;
  for (int step = 0; step < 3; ++step) {
    const Vector3d g = gradient(p);
    const double g2 = g.squaredNorm();
    if (g2 < 1e-12) break;
    p -= (value(p) - level) * g / g2;
  }
  return p;
}

DistanceField signed_distance(const imaging::LabelVolume& mask, double padding) {
  const imaging::LabelVolume in = padded(mask, voxels(mask.geometry, padding));
  BS_VERIFY(std::any_of(in.data.begin(), in.data.end(), [](std::uint8_t v) { return v != 0; }),
            "signed distance of an empty mask");
  const imaging::VolumeF d_in = imaging::distance_to_background(in);
  const imaging::VolumeF d_out = imaging::distance_to_background(complement(in));
  const double half = 0.5 * mask.geometry.spacing.minCoeff();
  imaging::VolumeF phi(in.geometry, 1, 0.0F);
  for (std::size_t v = 0; v < phi.data.size(); ++v)
    phi.data[v] = in.data[v] != 0 ? float(-(double(d_in.data[v]) - half))
                                  : float(double(d_out.data[v]) - half);
  return DistanceField(std::move(phi));
}

imaging::LabelVolume close_mask(const imaging::LabelVolume& mask, double radius, double padding) {
  imaging::LabelVolume m = padded(mask, voxels(mask.geometry, radius + padding));
  const imaging::VolumeF d_out = imaging::distance_to_background(complement(m));
  imaging::LabelVolume dilated(m.geometry, 1, 0);
  for (std::size_t v = 0; v < m.data.size(); ++v) dilated.data[v] = d_out.data[v] <= radius ? 1 : 0;
  const imaging::VolumeF d_in = imaging::distance_to_background(dilated);
  for (std::size_t v = 0; v < m.data.size(); ++v) m.data[v] = d_in.data[v] > radius ? 1 : 0;
  return m;
}

}  // namespace brainshift::data_synth
