#pragma once
/// @file
/// @brief Vessel centrelines from an angiogram (MRA, CTA; raw, skull-stripped or
/// background-suppressed; any integer or float range) or a power-Doppler volume: Gaussian
/// pre-filter → threshold from the vessels' own contrast above the background, never below a
/// robust noise floor (vessel_threshold.hpp) → connected components above a minimum size and
/// tubular enough (Frangi vesselness: skin, fat and other plates go) → exact distance transform
/// (radii) → topological thinning → skeleton graph → spur pruning → removal of pieces too short
/// for their calibre (blobs) → smoothing → resampling. Positions in world RAS mm, radii in mm.

#include "imaging/io/volume.hpp"
#include "imaging/vessels/histogram_threshold.hpp"
#include "imaging/vessels/skeleton_graph.hpp"
#include "imaging/vessels/support_edge.hpp"
#include "imaging/vessels/vessel_threshold.hpp"

#include <cstdint>
#include <limits>
#include <string>
#include <vector>

namespace brainshift::imaging {

/// Settings of extract_vessels(); the defaults suit a clinical MRA at ≈ 1 mm.
struct VesselExtractionOptions {
  /// Intensity threshold (image units; vessels are ≥ it). NaN: chosen by `threshold_method`.
  double threshold = std::numeric_limits<double>::quiet_NaN();
  /// Automatic threshold rule. VESSEL_CONTRAST: vessel_threshold.hpp. TISSUE_PEAK / OTSU (the
  /// former rules, for comparison): from the histogram, raised to the noise floor below; when
  /// TISSUE_PEAK finds none, Otsu is used (and reported).
  ThresholdMethod threshold_method = ThresholdMethod::VESSEL_CONTRAST;
  /// VESSEL_CONTRAST settings (vesselness scales and grid, seed level, contrast fraction).
  VesselContrastOptions contrast;
  /// VESSEL_CONTRAST: a kept component must have at least this share of its voxels in cells of
  /// vesselness ≥ tubular_vesselness × the maximum (plates such as the scalp's fat have none
  /// away from their rims); 0: no shape rule on components.
  double min_tubular_fraction = 0.1;
  double tubular_vesselness = 0.1;
  /// A result whose total length is below this is reported with a "few vessels" warning, mm.
  double few_vessels_mm = 50.0;
  /// TISSUE_PEAK: the count, relative to the tissue peak's, below which the tail starts.
  double tail_fraction = 0.02;
  HistogramOptions histogram;
  /// Gaussian pre-filter of the image before thresholding, standard deviation in mm; 0: none.
  /// Speckle and clutter are nearly independent from voxel to voxel while a vessel spans
  /// several voxels, so a filter of about one voxel averages the noise down (≈ 1/6 of its
  /// standard deviation at σ = 1 voxel) and barely moves a tube's axis.
  double prefilter_sigma_mm = 0.6;
  /// TISSUE_PEAK / OTSU noise floor (VESSEL_CONTRAST has its own, contrast.noise_floor_k): the
  /// threshold is raised to at least median + noise_floor_k × σ̂, σ̂ = 1.4826 × MAD of the raw
  /// image over the voxels above its minimum, scaled by the pre-filter's white-noise gain.
  /// Vessels are a sparse bright tail, so median and MAD describe the tissue/noise. 0: no floor.
  double noise_floor_k = 8.0;
  /// Hysteresis (Canny): a component is kept only when it reaches background + hysteresis_k × σ̂;
  /// 0: no hysteresis.
  double hysteresis_k = 0.0;
  /// 26-connected components smaller than this are noise, mm³ (20 mm³ ≈ 6 mm of a 1 mm-radius
  /// vessel).
  double min_component_mm3 = 20.0;
  /// Keep at most this many largest components; 0: all that pass `min_component_mm3`.
  int max_components = 0;
  /// Spurs (end-point-to-junction branches shorter than the rule) are removed.
  SpurPruning spurs;
  /// Shape rule on the connected pieces of the graph (after spur pruning): a piece is kept only
  /// when its centreline length is at least max(min_piece_length_mm, min_piece_elongation × its
  /// largest radius). Blobs (flash artefacts, spurious flow) thin to a point or a stub shorter
  /// than their radius; vessels are long for their calibre. 0 and 0: keep every piece.
  double min_piece_length_mm = 8.0;
  double min_piece_elongation = 4.0;
  /// (1/4, 1/2, 1/4) smoothing passes on each branch before resampling.
  int smoothing_passes = 3;
  /// Centreline point spacing after resampling, mm (2.5 mm intra-operatively); 0: keep the
  /// voxel centreline.
  double resample_step_mm = 2.5;
  /// Drop the centreline points whose vessel reaches the side of the ultrasound sector (the
  /// scanner's mask of exact zeros: a truncated tube, whose centreline lies inside the sector,
  /// deeper than the vessel; support_edge.hpp), those within their radius +
  /// support_edge_margin_mm of it. Off by default: on the phantoms the rule drops 32–51 of 87
  /// Doppler points (standard, seed 1; margin 0–1 mm) — the cortical vessels under a 15 mm probe
  /// face run along the sector's side — and still keeps some cut ones, which leaves the global
  /// start too few points (docs/history/BENCHMARKS_NOTEBOOK.md, "Never worse than rigid, v4").
  bool drop_at_support_edge = false;
  double support_edge_margin_mm = 1.0;  ///< mm, ≥ 0

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
  std::string message;  ///< why EMPTY; a one-line summary when OK
  VesselGraph graph;    ///< world RAS mm; empty when EMPTY
  double threshold = std::numeric_limits<double>::quiet_NaN();  ///< intensity used
  std::string threshold_rule;  ///< "given", "vessel contrast", "tissue peak", "Otsu", "Otsu
                               ///< (fallback)" or "noise floor"; "+ hysteresis" when seeded
  double noise_median = std::numeric_limits<double>::quiet_NaN();  ///< background level b
  double vessel_level = std::numeric_limits<double>::quiet_NaN();  ///< L (VESSEL_CONTRAST)
  bool background_suppressed = false;  ///< VESSEL_CONTRAST found a suppressed background
  double masked_fraction = 0.0;        ///< share of finite voxels at the image minimum
  int components_not_tubular = 0;      ///< dropped by the tubular-fraction rule
  std::vector<std::string> warnings;   ///< weak but usable input (weak contrast, few vessels)
  double noise_sigma = std::numeric_limits<double>::quiet_NaN();     ///< 1.4826 × MAD
  double seed_threshold = std::numeric_limits<double>::quiet_NaN();  ///< hysteresis seeds
  std::int64_t non_finite_voxels = 0;  ///< NaN/inf voxels, treated as background
  std::int64_t foreground_voxels = 0;  ///< voxels ≥ threshold
  int components_found = 0;            ///< 26-connected components above threshold
  int components_kept = 0;             ///< after the size rules
  double kept_volume_mm3 = 0.0;        ///< volume of the kept components
  std::int64_t skeleton_voxels = 0;    ///< after thinning
  int spurs_pruned = 0;
  int pieces_removed = 0;          ///< graph pieces failing the shape rule
  int branch_count = 0;            ///< branches of the final graph
  int junction_count = 0;          ///< nodes of degree ≥ 3
  int endpoint_count = 0;          ///< nodes of degree 1
  double total_length_mm = 0.0;    ///< sum of branch lengths
  int points_at_support_edge = 0;  ///< centreline points dropped at the sector's side
  bool sector_found = false;       ///< a sector mask was found (support_edge.hpp)
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
