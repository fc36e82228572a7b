#pragma once
/// @file
/// @brief A signed distance field on a voxel grid (mm, negative inside, world RAS): trilinear
/// values, finite-difference gradients, closest points on a level set. Used for surfaces that
/// come from label volumes (the dura-like brain hull, the skull hull around it).

#include "core/config.hpp"
#include "imaging/io/volume.hpp"

#include <cstdint>

namespace brainshift::data_synth {

class DistanceField {
 public:
  DistanceField() = default;
  /// @param[in] phi  one component, signed distance in mm (negative inside).
  explicit DistanceField(imaging::VolumeF phi);

  /// Trilinear value at x (world mm); outside the grid, the value at the nearest grid point plus
  /// the distance to it (so the field keeps growing away from the grid).
  [[nodiscard]] double value(const Vector3d& x) const;
  /// Gradient by central differences (half a voxel), world frame, 1 (mm/mm).
  [[nodiscard]] Vector3d gradient(const Vector3d& x) const;
  /// Unit normal (normalised gradient; +S when the gradient vanishes).
  [[nodiscard]] Vector3d normal(const Vector3d& x) const;
  /// The point of the level set {φ = level} reached from x along the gradient (three Newton
  /// steps), mm.
  [[nodiscard]] Vector3d closest_point(const Vector3d& x, double level = 0.0) const;
  [[nodiscard]] const imaging::VolumeF& volume() const { return m_phi; }

 private:
  imaging::VolumeF m_phi;
};

/// Signed distance (mm, negative inside, ±half a voxel at the boundary) of the non-zero voxels
/// of `mask`, on a grid padded by `padding` mm on every side. \throws brainshift::Error when the
/// mask is empty.
DistanceField signed_distance(const imaging::LabelVolume& mask, double padding);

/// Morphological closing of the non-zero voxels of `mask` by a ball of `radius` mm (dilation then
/// erosion through exact distance transforms), on a grid padded by radius + `padding` mm; fills
/// sulci narrower than about 2·radius. Voxels: 1 inside, 0 outside.
imaging::LabelVolume close_mask(const imaging::LabelVolume& mask, double radius, double padding);

}  // namespace brainshift::data_synth
