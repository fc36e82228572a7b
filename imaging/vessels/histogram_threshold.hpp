#pragma once
/// @file
/// @brief Intensity thresholds for bright vessels (MRA, power Doppler) from the histogram.

#include "imaging/io/volume.hpp"

#include <optional>

namespace brainshift::imaging {

/// How a vessel threshold is chosen from the histogram.
enum class ThresholdMethod {
  VESSEL_CONTRAST,  ///< from the tubes themselves (vessel_threshold.hpp), not the histogram
  TISSUE_PEAK,      ///< just after the tissue peak (seed 002): see tissue_peak_threshold()
  OTSU,             ///< Otsu's between-class-variance maximum (N. Otsu, IEEE SMC 9(1), 1979)
};

/// Histogram settings shared by the threshold rules.
struct HistogramOptions {
  int bins = 1024;               ///< over [min, max] of the finite voxel values
  int smoothing_half_width = 5;  ///< box filter of 2·w+1 bins before the peak search
};

/// "Just after the tissue peak": the lower edge of the first histogram bin above the mode
/// (the tissue, or background, peak) whose smoothed count drops below `tail_fraction` × the
/// mode's count. Vessels are the sparse bright tail beyond.
/// @param[in] image  one component; NaN and infinite voxels are ignored.
/// @param[in] tail_fraction  in (0, 1).
/// @return nothing when the image is constant or the histogram never drops that low.
std::optional<double> tissue_peak_threshold(const VolumeF& image, double tail_fraction,
                                            const HistogramOptions& options = {});

/// Otsu's threshold (the upper edge of the bin that maximises the between-class variance).
/// @return nothing when the image has fewer than two distinct finite values.
std::optional<double> otsu_threshold(const VolumeF& image, const HistogramOptions& options = {});

}  // namespace brainshift::imaging
