#pragma once
/// @file
/// @brief Synthetic pre-operative images on the label grid (world RAS mm): a T1-weighted-like MRI
/// from the labels (intensity per label, smooth multiplicative bias field, Gaussian noise) and
/// a time-of-flight-like MRA (dark tissue, vessels bright by radius with partial-volume edges,
/// noise). Intensities are arbitrary units.

#include "data_synth/vessels/vessel_tree.hpp"
#include "imaging/io/volume.hpp"

#include <cstdint>
#include <string>

namespace brainshift::data_synth {

struct MriOptions {
  std::uint32_t seed = 1;
  double background = 10.0;
  double brain = 500.0;
  double cortex = 380.0;          ///< grey-matter rim: brain voxels within cortex_thickness of the
  double cortex_thickness = 3.0;  ///< outside of the brain, mm (found by erosion of the label mask)
  double tumour = 750.0;          ///< contrast-enhanced
  double ventricles = 150.0;
  double bias_amplitude = 0.15;  ///< relative: the bias field lies in [1 − a, 1 + a]
  double noise_sigma = 12.0;
  [[nodiscard]] std::string validate() const;
};

/// MRI from the labels. \throws brainshift::Error on invalid options or a label out of {0..3}.
imaging::VolumeF make_mri(const imaging::LabelVolume& labels, const MriOptions& options);

struct MraOptions {
  std::uint32_t seed = 2;
  double background = 5.0;
  double tissue = 40.0;         ///< brain, tumour and ventricles
  double vessel_small = 250.0;  ///< peak of a vessel of radius min_radius
  double vessel_large = 450.0;  ///< peak of a vessel of radius ≥ large_radius
  double large_radius = 2.0;    ///< mm
  double noise_sigma = 8.0;
  [[nodiscard]] std::string validate() const;
};

/// MRA on the grid of `labels` with the (pre-operative) tree drawn as tubes.
imaging::VolumeF make_mra(const imaging::LabelVolume& labels, const VesselTree& tree,
                          const MraOptions& options);

}  // namespace brainshift::data_synth
