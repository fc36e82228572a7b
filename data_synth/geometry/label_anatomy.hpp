#pragma once
/// @file
/// @brief A phantom's anatomy from a label volume (0 background, 1 brain, 2 tumour, 3 ventricles;
/// world RAS mm): the real brain shape instead of the analytic ellipsoid.
///
/// - Outer surface (dura-like hull): the brain (labels 1-3) closed by a ball of closing_radius
///   (fills sulci), as a signed distance field smoothed by a Gaussian of hull_smoothing; the
///   skull (the truth solve's contact) is the brain closed by the larger skull_closing_radius
///   (convex-ish: no notch for a node to flip across), smoothed the same, grown by skull_gap.
/// - Craniotomy: a given point (projected onto the hull; more than max_craniotomy_distance from
///   it is an error), or by default the hull point furthest along `up` tilted 25° toward +R (the
///   upper convexity of the right hemisphere, off the midline fissure).
/// - Tumour: given (centre, radius), or the labels' own (label 2: centroid, equivalent-sphere
///   radius), or by default default_tumour_depth beneath the craniotomy centre along the
///   inward normal, radius default_tumour_radius; written into the labels (brain and ventricle
///   voxels within the radius become tumour).
/// - Truth mesh (make_label_mesh): cubes of PhantomMeshOptions::cell_size kept where the cube
///   centre is inside the hull, boundary nodes snapped onto it (phantom_mesh.hpp's rule against
///   flattened tetrahedra), independent of `prepare`'s CGAL mesh; the fixed base is the boundary
///   nodes within base_height of the lowest one along S (brain stem / skull base).

#include "data_synth/geometry/brain_shape.hpp"
#include "data_synth/geometry/distance_field.hpp"
#include "data_synth/geometry/phantom_mesh.hpp"
#include "imaging/io/volume.hpp"

#include <memory>
#include <optional>
#include <string>

namespace brainshift::data_synth {

struct LabelAnatomyOptions {
  std::optional<Vector3d> craniotomy;     ///< near the brain surface, world RAS mm
  std::optional<Vector3d> tumour_centre;  ///< inside the brain, world RAS mm
  std::optional<double> tumour_radius;    ///< mm, > 0
  Vector3d up{0.0, 0.0, 1.0};             ///< against gravity (default craniotomy), any length > 0
  double craniotomy_radius = 25.0;        ///< mm
  double default_tumour_depth = 30.0;     ///< tumour centre beneath the craniotomy centre, mm
  double default_tumour_radius = 10.0;    ///< mm
  double skull_gap = 2.5;                 ///< CSF layer between the hull and the skull, mm
  double closing_radius = 5.0;            ///< sulci narrower than ~2× this are filled, mm
  double skull_closing_radius = 12.0;     ///< the skull's closing (bridges concave notches), mm
  double hull_smoothing = 1.5;            ///< Gaussian sigma on the hull's distance field, mm
  double base_height = 10.0;  ///< fixed base: boundary nodes this close to the lowest, mm
  double max_craniotomy_distance = 15.0;  ///< a given craniotomy this far from the hull at most, mm
};

/// How a placement was chosen (for case.json).
enum class Placement { GIVEN, FROM_LABELS, DEFAULT };
std::string to_string(Placement p);

struct LabelAnatomy {
  imaging::LabelVolume labels;                     ///< the input with the tumour written in
  std::shared_ptr<const DistanceField> hull;       ///< outer brain surface (φ < 0 inside), mm
  std::shared_ptr<const DistanceField> skull;      ///< the hull grown by skull_gap, mm
  Vector3d craniotomy_centre = Vector3d::Zero();   ///< on the hull, mm
  Vector3d craniotomy_normal = Vector3d::UnitZ();  ///< outward unit normal of the hull there
  double craniotomy_radius = 25.0;                 ///< mm
  Placement craniotomy_placement = Placement::DEFAULT;
  Vector3d tumour_centre = Vector3d::Zero();  ///< mm
  double tumour_radius = 10.0;                ///< mm
  Placement tumour_placement = Placement::DEFAULT;
  double skull_gap = 2.5;        ///< mm
  double base_height = 10.0;     ///< mm
  double brain_volume_ml = 0.0;  ///< labels 1-3 (after the tumour is written)

  /// Label of the voxel nearest to x (0 outside the grid).
  [[nodiscard]] imaging::Label voxel_label(const Vector3d& x) const;
  /// voxel_label, with background inside the hull (sulci, closed gaps) counted as brain.
  [[nodiscard]] imaging::Label filled_label(const Vector3d& x) const;
  /// The shape for the vessel grower and the probe (filled labels, the hull).
  [[nodiscard]] BrainShape shape() const;
};

/// Builds the anatomy. `source` names the labels in error messages (e.g. the file name).
/// \throws brainshift::Error (one line naming the value) on a label outside 0-3, no brain, a
/// tumour centre outside the brain, a non-positive tumour radius, or a craniotomy far from it.
LabelAnatomy make_label_anatomy(const imaging::LabelVolume& labels,
                                const LabelAnatomyOptions& options, const std::string& source);

/// The truth mesh of the anatomy (see the file comment); base_nodes fixed, surface_nodes the
/// contact candidates. \throws brainshift::Error on invalid options or an empty mesh.
PhantomMesh make_label_mesh(const LabelAnatomy& anatomy, const PhantomMeshOptions& options);

}  // namespace brainshift::data_synth
