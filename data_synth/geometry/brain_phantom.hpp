#pragma once
/// @file
/// @brief Analytic brain phantom: a whole-brain ellipsoid with a flattened base, a spherical
/// tumour and two ellipsoidal lateral ventricles, inside a rigid ellipsoidal skull separated from
/// the brain by a CSF gap, with a circular craniotomy. Everything in world RAS mm; the brain's
/// semi-axes are along R (left-right), A (anterior-posterior), S (inferior-superior).
///
/// Labels (imaging::Label): 0 background, 1 brain, 2 tumour, 3 ventricles (CSF). The tumour and
/// the ventricles are labelled only inside the brain; the tumour wins over the ventricles.

#include "core/config.hpp"
#include "data_synth/geometry/ellipsoid.hpp"
#include "imaging/io/volume.hpp"

#include <string>

namespace brainshift::data_synth {

/// Parameters of the phantom (all lengths mm, positions world RAS mm). Defaults: an adult brain
/// of 140 × 170 × 120 mm (before the base cut) centred at a non-trivial scanner position, a
/// superficial right-frontal-parietal tumour of radius 12 mm, a craniotomy over the tumour.
struct PhantomGeometry {
  /// Centre of the brain ellipsoid, world RAS mm. The default puts the base plane (S = −18.5) half
  /// way between 1 mm voxel centres, so that voxel counts are not biased by half a layer.
  Vector3d centre{1.5, -17.0, 14.5};
  Vector3d semi_axes{70.0, 85.0, 60.0};  ///< brain ellipsoid semi-axes along R, A, S, mm
  /// Flattened base: the brain is cut by the plane S = centre.S − base_depth·semi_axes.S
  /// (dimensionless, in (0, 1]; 1 = no cut).
  double base_depth = 0.55;
  Vector3d tumour_offset{28.0, 22.0, 30.0};  ///< tumour centre − brain centre, mm (superficial)
  double tumour_radius = 12.0;               ///< mm, > 0
  /// Lateral ventricles: two ellipsoids at centre + (±ventricle_spacing/2, 0, 0) + ventricle_offset
  /// with semi-axes ventricle_semi_axes · ventricle_scale.
  Vector3d ventricle_offset{0.0, 0.0, 8.0};      ///< mm
  Vector3d ventricle_semi_axes{5.0, 22.0, 9.0};  ///< at scale 1, mm
  double ventricle_spacing = 20.0;               ///< distance between the two centres, mm
  double ventricle_scale = 1.0;                  ///< dimensionless, ≥ 0 (0: no ventricles)
  /// Craniotomy centre: where the ray centre + s·direction (s > 0) meets the brain surface
  /// (default: superior, over the right hemisphere).
  Vector3d craniotomy_direction{0.45, 0.35, 1.0};
  double craniotomy_radius = 25.0;  ///< radius of the skull opening, mm
  double skull_gap = 2.5;           ///< CSF layer between brain and skull, mm, ≥ 0

  /// Empty when valid, else the reason (names the value).
  [[nodiscard]] std::string validate() const;
  /// The brain ellipsoid (before the base cut).
  [[nodiscard]] Ellipsoid brain_ellipsoid() const { return {centre, semi_axes}; }
  /// The rigid skull: the brain ellipsoid grown by skull_gap on every semi-axis.
  [[nodiscard]] Ellipsoid skull() const;
  /// S coordinate of the flattened base plane, mm.
  [[nodiscard]] double base_level() const;
  [[nodiscard]] Vector3d tumour_centre() const { return centre + tumour_offset; }
  /// The two ventricle ellipsoids (left then right).
  [[nodiscard]] Ellipsoid ventricle(int side) const;
  /// Craniotomy centre on the brain surface, world RAS mm.
  [[nodiscard]] Vector3d craniotomy_centre_on_brain() const;
  /// Craniotomy centre on the skull (same ray), world RAS mm.
  [[nodiscard]] Vector3d craniotomy_centre_on_skull() const;
  /// True for points inside the brain (any non-background label).
  [[nodiscard]] bool inside_brain(const Vector3d& x) const;
  /// Label at world point x.
  [[nodiscard]] imaging::Label label_at(const Vector3d& x) const;
};

/// Analytic volumes of the labelled regions, mm³ (exact when the tumour and ventricles lie fully
/// inside the brain and do not overlap).
struct PhantomVolumes {
  double brain_total = 0.0;  ///< all non-background labels: the cut ellipsoid
  double tumour = 0.0;
  double ventricles = 0.0;
};
/// Cut-ellipsoid volume π a b c [(1 + d) − (1 + d³)/3] with d = base_depth, and the sphere and
/// ellipsoid volumes of the inclusions.
PhantomVolumes analytic_volumes(const PhantomGeometry& geometry);

/// Voxel grid of the label volume.
struct PhantomImageOptions {
  double spacing = 1.0;                       ///< isotropic voxel size, mm, > 0
  double margin = 5.0;                        ///< around the skull's bounding box, mm, ≥ 0
  Matrix3d direction = Matrix3d::Identity();  ///< image axes in world (orthonormal, det +1)
  /// Empty when valid, else the reason.
  [[nodiscard]] std::string validate() const;
};

/// Label volume of the phantom: each voxel gets label_at(its centre). The grid covers the skull
/// plus the margin in the image's own (possibly rotated) axes.
/// \throws brainshift::Error on invalid geometry or options.
imaging::LabelVolume make_label_volume(const PhantomGeometry& geometry,
                                       const PhantomImageOptions& options = {});

}  // namespace brainshift::data_synth
