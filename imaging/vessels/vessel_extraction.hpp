#pragma once
/// @file
/// @brief Vessel centrelines from an angiogram (MRA) or a power-Doppler volume: histogram
/// threshold → connected components above a minimum size → exact distance transform (radii) →
/// topological thinning → skeleton graph → spur pruning → smoothing → resampling.
/// Positions in world RAS mm, radii in mm.

#include <cstdint>
#include <limits>
#include <string>

#include "imaging/io/volume.hpp"
#include "imaging/vessels/histogram_threshold.hpp"
#include "imaging/vessels/skeleton_graph.hpp"

namespace brainshift::imaging {

/// Settings of extract_vessels(); the defaults suit a clinical MRA at ≈ 1 mm.
struct VesselExtractionOptions {
  /// Intensity threshold (image units; vessels are ≥ it). NaN: chosen by `threshold_method`.
  double threshold = std::numeric_limits<double>::quiet_NaN();
  /// Automatic threshold rule; when TISSUE_PEAK finds none, Otsu is used (and reported).
  ThresholdMethod threshold_method = ThresholdMethod::TISSUE_PEAK;
  /// TISSUE_PEAK: the count, relative to the tissue peak's, below which the tail starts.
  double tail_fraction = 0.02;
  HistogramOptions histogram;
  /// 26-connected components smaller than this are noise, mm³ (20 mm³ ≈ 6 mm of a 1 mm-radius
  /// vessel).
  double min_component_mm3 = 20.0;
  /// Keep at most this many largest components; 0: all that pass `min_component_mm3`.
  int max_components = 0;
  /// Spurs (end-point-to-junction branches shorter than the rule) are removed.
  SpurPruning spurs;
  /// (1/4, 1/2, 1/4) smoothing passes on each branch before resampling.
  int smoothing_passes = 3;
  /// Centreline point spacing after resampling, mm (2.5 mm intra-operatively); 0: keep the
  /// voxel centreline.
  double resample_step_mm = 2.5;

  /// Empty when valid, else what is wrong.
  [[nodiscard]] std::string validate() const;
};

/// Outcome of extract_vessels().
enum class VesselStatus {
  OK,     ///< a graph with at least one branch
  EMPTY,  ///< no vessel found; `message` says why (constant image, nothing above threshold…)
};

/// The vessel graph and a report of each stage.
struct VesselExtractionResult {
  VesselStatus status = VesselStatus::EMPTY;
  std::string message;                          ///< why EMPTY; a one-line summary when OK
  VesselGraph graph;                            ///< world RAS mm; empty when EMPTY
  double threshold = std::numeric_limits<double>::quiet_NaN();  ///< intensity used
  std::string threshold_rule;                   ///< "given", "tissue peak" or "Otsu (fallback)"
  std::int64_t non_finite_voxels = 0;           ///< NaN/inf voxels, treated as background
  std::int64_t foreground_voxels = 0;           ///< voxels ≥ threshold
  int components_found = 0;                     ///< 26-connected components above threshold
  int components_kept = 0;                      ///< after the size rules
  double kept_volume_mm3 = 0.0;                 ///< volume of the kept components
  std::int64_t skeleton_voxels = 0;             ///< after thinning
  int spurs_pruned = 0;
  int branch_count = 0;                         ///< branches of the final graph
  int junction_count = 0;                       ///< nodes of degree ≥ 3
  int endpoint_count = 0;                       ///< nodes of degree 1
  double total_length_mm = 0.0;                 ///< sum of branch lengths
};

/// Extracts vessel centrelines from a bright-vessel volume.
/// @param[in] image  one component (MRA or power Doppler); NaN voxels are background and
/// counted in the report.
/// @param[in] options  see VesselExtractionOptions.
/// @return the graph and report; status EMPTY (never an exception) when no vessel is found.
/// \throws brainshift::Error for invalid options or a volume that is not one-component or whose
/// data size does not match its grid.
VesselExtractionResult extract_vessels(const VolumeF& image,
                                       const VesselExtractionOptions& options = {});

}  // namespace brainshift::imaging
