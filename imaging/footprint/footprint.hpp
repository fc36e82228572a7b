#pragma once
/// @file
/// @brief The probe footprint from a B-mode volume: where the tracked probe
/// touches the brain, as points with normals for the footprint constraint rows.
///
/// The contact shows as a bright band at the top of the sector. Beam lines (rays parallel to
/// the probe axis, one per node of a grid over the face aperture) are resampled from the volume
/// into the probe frame and low-pass filtered (Gaussian); on each ray the band is the first
/// sample at or above an intensity threshold (Otsu of the top slab, a fraction of its maximum, or
/// given). The rays with a band form a depth map over the face; its largest depth-continuous
/// patch is kept and sampled on a lattice of step `sample_spacing_mm` (10 mm), each sample being
/// the value, at the lattice node, of a local quadric (or plane) least-squares fit of the patch
/// depths in a disc around it (one refit without outliers). The normal is that fit's, oriented
/// into the tissue (n · axis > 0).
///
/// Probe frame: u = lateral (along the array), v = axis × u (elevation), w = axis (beam, into the
/// tissue); (u, v, w) is right-handed. A face point (x, y) at depth z is the world point
/// face_centre + x·u + y·v + z·w (RAS, mm).

#include "core/config.hpp"
#include "imaging/io/volume.hpp"
#include "imaging/vessels/histogram_threshold.hpp"

#include <cstdint>
#include <limits>
#include <optional>
#include <string>

namespace brainshift::imaging {

/// Pose of the tracked probe at the time of the B-mode volume, world RAS mm.
struct ProbePose {
  Vector3d face_centre = Vector3d::Zero();  ///< centre of the contact face, mm
  Vector3d axis = Vector3d::UnitZ();        ///< beam direction, into the tissue (normalised here)
  /// Lateral direction (along the array); made orthogonal to `axis`. When absent, the world
  /// axis least aligned with `axis`, made orthogonal to it.
  std::optional<Vector3d> lateral;
};

/// How the band threshold is chosen when FootprintOptions::threshold is NaN.
enum class FootprintThreshold {
  OTSU,             ///< Otsu's threshold of the filtered samples of the top slab
  FRACTION_OF_MAX,  ///< `threshold_fraction` × the largest filtered sample of the top slab
};

/// Which depth of the band is reported for a ray.
enum class FootprintDepthRule {
  /// The (parabolically interpolated) maximum of the filtered profile within `band_search_mm`
  /// after the first threshold crossing: the centre of the interface echo, which is centred on
  /// the interface, so neither the blur nor the threshold moves it; brighter tissue right below
  /// the band does, deeper, by ≈ 0.25 mm in the tests (1.5 mm band, tissue at 0.3 of the band's
  /// echo, σ = 1 mm).
  BAND_CENTRE,
  /// The first threshold crossing itself (linearly interpolated): the leading edge of the band,
  /// shallower than its centre by up to about half its filtered width, depending on the threshold.
  THRESHOLD_CROSSING,
};

/// Settings of extract_footprint(). Distances in mm in the probe frame.
struct FootprintOptions {
  double aperture_width_mm = 40.0;      ///< lateral extent of the ray grid (a linear array face)
  double aperture_elevation_mm = 10.0;  ///< elevation extent of the ray grid
  double grid_step_mm = 0.5;            ///< spacing of the rays over the face, > 0
  double depth_step_mm = 0.25;          ///< sample spacing along each ray, > 0
  double min_depth_mm = 0.0;            ///< the top slab starts here (0 = at the face)
  double max_depth_mm = 25.0;           ///< … and ends here: the band is searched within it
  double smoothing_sigma_mm = 1.0;      ///< Gaussian low-pass (3-D, probe frame); 0: none

  /// Band threshold (image units). NaN: chosen by `threshold_rule`.
  double threshold = std::numeric_limits<double>::quiet_NaN();
  FootprintThreshold threshold_rule = FootprintThreshold::OTSU;
  double threshold_fraction = 0.5;  ///< FRACTION_OF_MAX, in (0, 1)
  HistogramOptions histogram;       ///< OTSU's histogram
  /// Band-versus-rest contrast needed to accept the threshold: mean of the slab samples ≥ it over
  /// the mean of those below. Speckle alone, split by Otsu, stays near 1.1–1.5.
  double min_contrast = 2.0;

  FootprintDepthRule depth_rule = FootprintDepthRule::BAND_CENTRE;
  double band_search_mm = 3.0;  ///< BAND_CENTRE: how far past the crossing to look, > 0
  /// Missing samples at the start of a ray are outside the swept region, in front of the probe
  /// face (freehand volumes, 0 outside the sector): a crossing right after them is the band.
  /// Otherwise (default) a crossing right after missing data is refused (the band may be in the
  /// gap).
  bool leading_missing_is_outside = false;
  /// Adjacent rays (8-neighbours) belong to one patch when their depths differ by at most this:
  /// at the default grid step, surfaces up to ≈ 55° from the face plane stay one patch.
  double max_depth_jump_mm = 1.0;
  double min_patch_area_mm2 = 10.0;  ///< a smaller largest patch is "no contact band"

  double sample_spacing_mm = 10.0;  ///< lattice step of the output points, > 0
  /// Disc of patch rays fitted around each output point. Where it is less than ¾ full (the
  /// patch's edge) it grows by 25 % steps up to twice this, so one-sided fits keep about as many
  /// rays. On speckled synthetic bands (tests), 5 mm gave normals up to 8° off at the edge,
  /// 7.5 mm ≤ 1.7°.
  double fit_radius_mm = 7.5;
  int min_fit_points = 10;  ///< fewer in the disc: the lattice node is skipped (≥ 3)

  /// Empty when valid, else what is wrong.
  [[nodiscard]] std::string validate() const;
};

/// Outcome of extract_footprint().
enum class FootprintStatus {
  OK,       ///< at least one footprint point
  NO_BAND,  ///< "no contact band found": `message` says why; no points
};

/// Footprint points and a report of each stage.
struct FootprintResult {
  FootprintStatus status = FootprintStatus::NO_BAND;
  std::string message;  ///< why NO_BAND ("no contact band found: …"); a summary when OK
  MatrixX3d points;     ///< #P×3 contact points, world RAS mm (finite)
  MatrixX3d normals;    ///< #P×3 unit surface normals into the tissue (n · axis > 0)
  double threshold = std::numeric_limits<double>::quiet_NaN();  ///< intensity used (NaN if none)
  std::string threshold_rule;        ///< "given", "Otsu" or "fraction of max"
  double contrast = 0.0;             ///< see FootprintOptions::min_contrast
  int rays = 0;                      ///< rays over the face
  int rays_with_band = 0;            ///< rays with a threshold crossing
  int patches = 0;                   ///< depth-continuous patches of such rays
  int patch_rays = 0;                ///< rays of the largest patch
  double patch_area_mm2 = 0.0;       ///< its area on the face
  double patch_width_mm = 0.0;       ///< its extent along the lateral direction u (ray centres)
  double patch_elevation_mm = 0.0;   ///< its extent along the elevation direction v
  int lattice_nodes = 0;             ///< lattice nodes on the patch
  int nodes_skipped = 0;             ///< of those, too few or degenerate fit points
  std::int64_t missing_samples = 0;  ///< ray samples outside the volume or among NaN voxels
};

/// Extracts the probe footprint from a B-mode volume.
/// @param[in] bmode  one component, world RAS mm; NaN/inf voxels and samples outside the grid
/// are missing data (never propagated into points).
/// @param[in] pose  the probe at acquisition.
/// @param[in] options  see FootprintOptions.
/// @return the points and report; status NO_BAND (never an exception) for an empty, constant or
/// dark image or one without a band under the face.
/// \throws brainshift::Error for invalid options, a non-finite pose, a zero axis, a lateral
/// direction parallel to the axis, or a volume that is not one-component or whose data size
/// does not match its grid.
FootprintResult extract_footprint(const VolumeF& bmode, const ProbePose& pose,
                                  const FootprintOptions& options = {});

}  // namespace brainshift::imaging
