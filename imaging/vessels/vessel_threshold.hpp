#pragma once
/// @file
/// @brief The vessel threshold from the data itself ("vessel contrast" rule): find the tubes
/// first, then put the threshold part of the way from the background up to them.
///
/// 1. Multi-scale Frangi vesselness (imaging/filters/vesselness.hpp) on a grid of about
///    `grid_mm` (block means of the pre-filtered image), so it costs little on a large volume.
/// 2. Vessel level L: the median, over the seed cells (vesselness ≥ seed_vesselness × its
///    maximum), of the brightest pre-filtered voxel of the cell — what a vessel centre looks like
///    in this image. L is an image value, so L ≤ the image's maximum.
/// 3. Background b: the median of the block means in a ring 2–4 cells from the seeds that are not
///    tubular themselves (the tissue the vessels run in); without such cells, the median of the
///    reference voxels: all finite voxels, or, when at least half of them hold the minimum value
///    (a masked image: background-suppressed or skull-stripped MRA, an ultrasound field of view),
///    the voxels above the minimum. Noise σ̂: 1.4826 × MAD / √2 of the differences of reference
///    voxels ≈ 3 mm apart in that ring (tissue levels and coil bias cancel; correlated noise
///    counts in full). When the reference voxels of a masked image are themselves as bright as
///    the vessels (median ≥ halfway to L: a background-suppressed angiogram keeps only the
///    vessels), the background is the minimum and its noise 0.
/// 4. Threshold T = max(b + contrast_fraction × (L − b), b + noise_floor_k × σ̂). With the
///    default fraction ½ the threshold is the half-maximum of the vessels' contrast, where a
///    blurred tube's wall lies. T < L ≤ maximum always; when the noise floor reaches L there are
///    no vessels above the noise (EMPTY); when it sets T above the half-maximum rule the contrast
///    is weak (a warning).

#include "imaging/filters/vesselness.hpp"
#include "imaging/io/volume.hpp"

#include <cstdint>
#include <limits>
#include <string>

namespace brainshift::imaging {

/// Settings of the vessel-contrast threshold (see the file comment).
struct VesselContrastOptions {
  filters::VesselnessOptions vesselness;  ///< scales 1 and 2 mm by default
  double grid_mm = 1.0;            ///< vesselness grid spacing, mm (never finer than the image)
  double seed_vesselness = 0.5;    ///< seed cells: vesselness ≥ this × its maximum, in (0, 1]
  double contrast_fraction = 0.5;  ///< T = b + this × (L − b), in (0, 1)
  /// The noise floor b + noise_floor_k × σ̂ (σ̂ of the pre-filtered image, measured near the
  /// vessels): 4 σ̂ leaves ≈ 3e-5 of Gaussian background voxels above it, specks that the size
  /// and shape rules remove. ≥ 0.
  double noise_floor_k = 4.0;
  /// Empty when valid, else what is wrong.
  [[nodiscard]] std::string validate() const;
};

/// Outcome of vessel_contrast_threshold().
struct VesselContrast {
  double threshold = std::numeric_limits<double>::quiet_NaN();  ///< image units; NaN when none
  std::string rule;          ///< "vessel contrast" or "noise floor"
  std::string empty_reason;  ///< why no threshold (then threshold is NaN)
  std::string warning;       ///< weak contrast, when the noise floor set T
  double vessel_level = std::numeric_limits<double>::quiet_NaN();      ///< L
  double background_level = std::numeric_limits<double>::quiet_NaN();  ///< b
  double noise_sigma = std::numeric_limits<double>::quiet_NaN();       ///< σ̂
  double masked_fraction = 0.0;  ///< share of finite voxels at the minimum
  bool background_suppressed = false;
  VolumeF vesselness;                                ///< on the coarse grid (block factor `factor`)
  Eigen::Vector3i factor = Eigen::Vector3i::Ones();  ///< image voxels per vesselness cell
  double vesselness_max = 0.0;
  std::int64_t seed_cells = 0;
};

/// The vessel-contrast threshold of `filtered` (the pre-filtered image, same grid); `image`
/// (unfiltered) decides which voxels are masked (exactly its minimum).
/// @return the threshold, or NaN with `empty_reason` when there are no vessels to find.
VesselContrast vessel_contrast_threshold(const VolumeF& image, const VolumeF& filtered,
                                         const VesselContrastOptions& options);

}  // namespace brainshift::imaging
