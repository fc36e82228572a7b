#pragma once
/// @file
/// @brief The probe footprint from a B-mode volume without a probe pose:
/// freehand reconstructions on oblique grids, and our phantoms' probe-aligned volumes alike.
///
/// 1. The beam direction and the narrow (near-field) end of the swept region come from
///    estimate_beam() (or the beam is given, e.g. by the tracked probe);
/// 2. voxels outside the swept region (exactly 0) become missing data, so that neither the band
///    threshold nor the contrast counts the empty corners of the grid;
/// 3. extract_footprint() casts rays along the beam over the narrow end, from `margin_mm` in
///    front of it to `search_depth_mm` beyond it: the contact band is the first bright echo;
/// 4. the band must stand out from the tissue under it (`min_band_contrast`, from the RESECT
///    volumes with and without their band) and lie at the edge of the swept region, where the
///    probe face was (`max_face_distance_mm`); else there is no contact band.
/// Each doubt about a footprint that was found becomes a warning (never a silent success): a
/// narrow patch (a face is 10–40 mm wide), dropped points, or a region that fits a fan poorly.
/// World RAS, mm.

#include "imaging/footprint/beam_direction.hpp"
#include "imaging/footprint/footprint.hpp"

#include <optional>
#include <string>
#include <vector>

namespace brainshift::imaging {

/// Settings of extract_freehand_footprint().
struct FreehandFootprintOptions {
  BeamOptions beam;
  double margin_mm = 5.0;         ///< rays start this far in front of the narrow end, > 0
  double search_depth_mm = 15.0;  ///< … and reach this far beyond it, > 0
  /// Otsu split contrast of the ray samples (FootprintOptions::min_contrast): only a guard
  /// against flat images here; the band contrast below decides.
  double min_slab_contrast = 1.2;
  /// Band contrast needed: median over the points of the band's mean echo (±1 mm, 3 mm disc)
  /// over the tissue's 3-15 mm below. RESECT (docs/history/BENCHMARKS_NOTEBOOK.md): 1.51-3.68
  /// (median 2.4) with the band; 0.70-1.64 (median 1.0) with the first 4 mm cut away. 1.5 keeps the
  /// weakest band seen and refuses all but 2 of 17 band-less volumes; our synthetic band-less
  /// speckle: ≈ 1.0.
  double min_band_contrast = 1.5;
  double smoothing_sigma_mm = 1.0;  ///< see FootprintOptions
  double sample_spacing_mm = 10.0;  ///< see FootprintOptions
  double min_width_mm = 10.0;       ///< a narrower contact patch is a warning
  /// Points deeper below the swept region's edge are not the contact: dropped (a warning); none
  /// left is no band. The band lies 0-3 mm below it on RESECT.
  double max_face_distance_mm = 5.0;
  double min_fan_fit = 0.5;  ///< a worse fan fit (estimated beam) is a warning
  /// Empty when valid, else what is wrong.
  [[nodiscard]] std::string validate() const;
};

/// Footprint, beam and plausibility figures.
struct FreehandFootprint {
  BeamEstimate beam;
  /// Points, normals (into the tissue), status, threshold; `contrast` is the band contrast
  /// (median over the points, see FreehandFootprintOptions::min_band_contrast).
  FootprintResult footprint;
  /// Per point: depth below the first swept voxel met going back along the beam, mm (how far
  /// the band is from the near edge of the swept region).
  std::vector<double> face_distance_mm;
  std::vector<double> band_contrast;  ///< per point: band echo over the tissue 3-15 mm below
  /// The patch's smaller extent (the probe face's width; a sweep's length is the larger one).
  double width_mm = 0.0;
  double elevation_mm = 0.0;          ///< the patch's larger extent
  std::vector<std::string> warnings;  ///< one line each
};

/// Finds the beam (or takes `direction`, from the probe into the tissue) and the contact band.
/// No band is not an exception: footprint.status is NO_BAND and footprint.message says why.
/// \throws brainshift::Error as estimate_beam() and extract_footprint() do, and for invalid
/// options.
FreehandFootprint extract_freehand_footprint(const VolumeF& bmode,
                                             const std::optional<Vector3d>& direction = {},
                                             const FreehandFootprintOptions& options = {});

}  // namespace brainshift::imaging
