#pragma once
/// @file
/// @brief The probe's beam direction and face from a B-mode volume alone.
///
/// A tracked B-mode volume is a fan (one sector image) or a sweep of fans (a freehand
/// reconstruction); voxels outside the swept region are 0 (or NaN). Its grid need not follow the
/// probe: freehand volumes sit on oblique grids whose axes are not the beam. What the data show
/// (the 17 RESECT volumes, docs/history/BENCHMARKS_NOTEBOOK.md): the swept region is a frustum-like
/// prism whose cross-section grows linearly with depth along the beam (the sector widens laterally;
/// the sweep adds elevation, constant or widening), its slab centroids stay on the beam axis, and
/// its narrow (near-field) end is the probe face.
///
/// The estimate, from the swept voxels (a regular subsample):
/// 1. every direction d of a Fibonacci sphere gets a fan score: the linear growth of the
///    cross-section area along d over the whole depth (relative to the largest cross-section)
///    minus twice the drift of the slab centroids across d (tan of the angle between the centroid
///    line and d). Diagonals through a prism also grow but their centroids wander, and they grow
///    from a corner;
/// 2. each local maximum (15° neighbourhood) is fitted with a frustum: per 1 mm slab the 2nd and
///    98th percentiles of the two transverse coordinates (transverse axes turned in 5° steps),
///    four straight edges fitted over the well-filled slabs; its intersection over union with the
///    swept region is the fan fit. The best candidate is refined by local search on the fit;
/// 3. the direction points from the narrow end to the wide end; the lateral axis is the
///    transverse axis along which the frustum widens most.
/// With a given direction only steps 2–3's frustum is fitted (its fit still reported).
/// Distances in mm, directions unit vectors, world RAS.

#include "core/config.hpp"
#include "imaging/io/volume.hpp"

#include <cstdint>
#include <optional>
#include <string>

namespace brainshift::imaging {

/// Settings of estimate_beam().
struct BeamOptions {
  int max_points = 15000;  ///< swept voxels used (a regular subsample), >= 1000
  int directions = 1500;   ///< candidate directions over the sphere, >= 100
  double slab_mm = 1.0;    ///< slab thickness of the frustum fit, > 0
  /// Empty when valid, else what is wrong.
  [[nodiscard]] std::string validate() const;
};

/// The beam and the swept region's frustum, world RAS mm.
struct BeamEstimate {
  Vector3d direction = Vector3d::UnitZ();   ///< unit, from the probe into the tissue
  Vector3d lateral = Vector3d::UnitX();     ///< unit, ⊥ direction: the axis of most widening
  Vector3d elevation = Vector3d::UnitY();   ///< direction × lateral
  Vector3d face_centre = Vector3d::Zero();  ///< centre of the frustum's narrow end, mm
  double near_width_mm = 0.0;               ///< frustum extent along `lateral` at the narrow end
  double near_elevation_mm = 0.0;           ///< … along `elevation`
  double far_width_mm = 0.0;                ///< … along `lateral` at the wide end
  double far_elevation_mm = 0.0;            ///< … along `elevation` at the wide end
  double depth_mm = 0.0;                    ///< extent of the swept region along `direction`
  double fan_fit = 0.0;           ///< intersection over union, frustum vs swept region, [0, 1]
  bool given = false;             ///< the direction came from the caller
  std::int64_t swept_voxels = 0;  ///< voxels that are finite and non-zero
};

/// Finds the beam direction and the probe face of a B-mode volume (see the file comment), or
/// fits the frustum along `given` (any length, normalised here) when one is passed.
/// @param[in] bmode  one component; the swept region is its finite non-zero voxels.
/// \throws brainshift::Error for invalid options, a volume that is not one-component, a zero or
/// non-finite `given`, or fewer than 100 swept voxels ("no swept region").
BeamEstimate estimate_beam(const VolumeF& bmode, const std::optional<Vector3d>& given = {},
                           const BeamOptions& options = {});

}  // namespace brainshift::imaging
