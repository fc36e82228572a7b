#pragma once
/// @file
/// @brief Multi-scale Hessian vesselness of bright tubes (A. F. Frangi, W. J. Niessen,
/// K. L. Vincken, M. A. Viergever, "Multiscale vessel enhancement filtering", MICCAI 1998).
///
/// At each scale σ the image is smoothed by a Gaussian (gaussian.hpp) and its Hessian H taken by
/// central differences (mm⁻², scale-normalised by σ²). With the eigenvalues sorted
/// |λ1| ≤ |λ2| ≤ |λ3|, a bright tube has λ2, λ3 ≪ 0 and λ1 ≈ 0:
///
///   V = (1 − exp(−Ra²/2α²)) · exp(−Rb²/2β²) · (1 − exp(−S²/2c²))  when λ2 < 0 and λ3 < 0, else 0,
///   Ra = |λ2|/|λ3| (plate vs line), Rb = |λ1|/√|λ2λ3| (blob vs line), S = ‖H‖_F (structure),
///
/// with c = c_fraction × the largest S at that scale. The response is the maximum over the
/// scales, in [0, 1). Only voxels brighter than the smoothed image's median are evaluated (a
/// bright tube's centre is); a scale of ≥ 2 voxels is computed on a grid block-averaged by
/// ⌊σ/2h⌋ and read back at each voxel's block, so large scales cost little. A tube of radius r
/// responds most at σ ≈ r/√2 (Sato et al. 1998); plates (skin, fat, the skull's edge) have
/// Ra ≈ 0 and blobs Rb ≈ 1, so both are suppressed.

#include "imaging/io/volume.hpp"

#include <vector>

namespace brainshift::imaging::filters {

/// Settings of frangi_vesselness().
struct VesselnessOptions {
  /// Gaussian σ per scale, mm (> 0). A tube of radius r responds most at σ ≈ r/√2: 1 and 2 mm
  /// cover the intracranial vessels (radius ≈ 0.7–3 mm); larger scales also see anatomy (a
  /// flattened brain's rim, a bias-field ridge) as tubes.
  std::vector<double> scales_mm{1.0, 2.0};
  double alpha = 0.5;       ///< plate-vs-line sensitivity (Frangi's α)
  double beta = 0.5;        ///< blob-vs-line sensitivity (Frangi's β)
  double c_fraction = 0.5;  ///< c = this × the largest Hessian norm at the scale (Frangi: ½)
  /// Empty when valid, else what is wrong.
  [[nodiscard]] std::string validate() const;
};

/// The vesselness of every voxel, on the grid of `image` (call downsample() first to work on a
/// coarser grid). Non-finite voxels count as 0; a grid axis of one voxel has zero curvature.
/// @param[in] image  one component.
/// @return a one-component volume in [0, 1), same grid.
/// \throws brainshift::Error for invalid options or a multi-component volume.
VolumeF frangi_vesselness(const VolumeF& image, const VesselnessOptions& options = {});

}  // namespace brainshift::imaging::filters
