#pragma once
/// @file
/// @brief What the vessel grower, the probe placement and the image renderers need to know about
/// a phantom's brain, independent of how the brain is described (the analytic ellipsoid of
/// PhantomGeometry, or a label volume: label_anatomy.hpp). World RAS mm throughout.

#include "core/config.hpp"
#include "data_synth/geometry/brain_phantom.hpp"
#include "imaging/io/volume.hpp"

#include <functional>

namespace brainshift::data_synth {

/// A brain shape: labels, its smooth outer (dura-like) surface, the tumour and the craniotomy.
struct BrainShape {
  /// Label at a world point (0 outside the brain; sulci inside the hull count as brain).
  std::function<imaging::Label(const Vector3d&)> label_at;
  /// Closest point of the outer brain surface to x, mm.
  std::function<Vector3d(const Vector3d&)> closest_surface_point;
  /// Outward unit normal of the outer surface at (or near) a surface point.
  std::function<Vector3d(const Vector3d&)> surface_normal;
  Vector3d craniotomy_centre = Vector3d::Zero();  ///< on the brain surface, mm
  double craniotomy_radius = 25.0;                ///< mm
  Vector3d tumour_centre = Vector3d::Zero();      ///< mm
  double tumour_radius = 10.0;                    ///< mm
  /// Vessels stay this S level + 3 mm or above (the flattened base; −∞: no limit), mm.
  double base_level = -1e300;
};

/// The shape of the analytic phantom (the ellipsoid, its base cut, tumour and craniotomy).
BrainShape brain_shape(const PhantomGeometry& geometry);

}  // namespace brainshift::data_synth
