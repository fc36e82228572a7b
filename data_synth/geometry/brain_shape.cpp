#include "data_synth/geometry/brain_shape.hpp"

namespace brainshift::data_synth {

BrainShape brain_shape(const PhantomGeometry& geometry) {
  BrainShape s;
  const Ellipsoid brain = geometry.brain_ellipsoid();
  s.label_at = [geometry](const Vector3d& x) { return geometry.label_at(x); };
  s.closest_surface_point = [brain](const Vector3d& x) { return brain.closest_point(x); };
  s.surface_normal = [brain](const Vector3d& x) { return brain.normal(x); };
  s.craniotomy_centre = geometry.craniotomy_centre_on_brain();
  s.craniotomy_radius = geometry.craniotomy_radius;
  s.tumour_centre = geometry.tumour_centre();
  s.tumour_radius = geometry.tumour_radius;
  s.base_level = geometry.base_level();
  return s;
}

}  // namespace brainshift::data_synth
