#pragma once
/// @file
/// @brief Synthetic intra-operative ultrasound volumes on the probe grid, rendered in the
/// deformed (intra-operative) space: power Doppler of the deformed vessel tree and B-mode of
/// the deformed anatomy with the probe contact band. Nothing outside the probe's field of view
/// carries signal (exactly 0). Intensities in [0, 255] (arbitrary units).

#include "data_synth/geometry/brain_phantom.hpp"
#include "data_synth/images/probe.hpp"
#include "data_synth/truth/truth_field.hpp"
#include "data_synth/vessels/vessel_tree.hpp"
#include "imaging/io/volume.hpp"

#include <cstdint>
#include <functional>
#include <string>

namespace brainshift::data_synth {

/// Labels of the deformed anatomy on `grid`: each voxel inside a deformed truth tetrahedron is
/// mapped back to its rest position X (barycentric) and takes geometry.label_at(X); voxels
/// outside the deformed brain are 0. With `resected`, tumour voxels become 0 (a fluid cavity).
imaging::LabelVolume deformed_labels(const TruthField& truth, const PhantomGeometry& geometry,
                                     const imaging::ImageGeometry& grid, bool resected);
/// The same with the rest labels of any anatomy (e.g. a label volume).
imaging::LabelVolume deformed_labels(const TruthField& truth,
                                     const std::function<imaging::Label(const Vector3d&)>& label_at,
                                     const imaging::ImageGeometry& grid, bool resected);

struct DopplerOptions {
  std::uint32_t seed = 3;
  double thickening_scale = 1.4;  ///< drawn radius = r · scale + add (blooming), mm
  double thickening_add = 0.4;    ///< mm
  double blur_sigma = 0.7;        ///< mm
  double speckle_shape = 4.0;     ///< gamma shape of the multiplicative speckle (larger: less)
  double dropout = 0.15;          ///< expected fraction of vessel length missing, in [0, 0.4]
  double dropout_run = 8.0;       ///< mean length of a missing run, in segments, ≥ 1
  int spurious_blobs = 4;         ///< flow blobs not on the tree, ≥ 0
  double clutter_sigma = 3.0;     ///< additive background noise (of 255)
  [[nodiscard]] std::string validate() const;
};

/// Power Doppler: the deformed tree (points already in the intra-operative space) as thickened,
/// blurred, speckled tubes with dropout, plus spurious blobs inside the deformed brain.
/// @param[in] deformed_tree  the tree with intra-operative positions, mm RAS.
/// @param[in] labels  deformed_labels() on probe.grid().
imaging::VolumeF make_doppler(const Probe& probe, const VesselTree& deformed_tree,
                              const imaging::LabelVolume& labels, const DopplerOptions& options);

struct BmodeOptions {
  std::uint32_t seed = 4;
  double brain = 0.45;  ///< echogenicity of parenchyma, in [0, 1]
  double tumour = 0.8;
  double ventricles = 0.05;
  double fluid = 0.03;         ///< outside the brain (saline, CSF) and in a resection cavity
  double attenuation = 0.008;  ///< 1/mm: intensity × exp(−attenuation · depth)
  /// The contact band: the interface echo of the brain surface under the probe face, this deep
  /// below the surface, mm. Real B-mode (RESECT, 17 volumes): a band about 2 mm thick (FWHM 1.5-
  /// 2.5 mm) at the top of the sector, its echo 1.5-3.7 × the tissue's below (median 2.4).
  double band_thickness = 2.0;
  double band = 1.0;  ///< brightness of the contact band, in [0, 1] (≈ 2.2 × brain)
  /// The band is drawn where the brain surface lies within this depth below the face (in
  /// contact, or under a thin film of saline or gel), mm.
  double contact_gap = 3.0;
  double speckle_blur = 0.4;  ///< mm: correlation of the Rayleigh speckle
  [[nodiscard]] std::string validate() const;
};

/// B-mode: echogenicity by deformed label with Rayleigh speckle and depth attenuation, and the
/// bright contact band: `band_thickness` deep under the deformed brain's surface wherever that
/// surface lies within `contact_gap` below the probe face (the grid's k axis is the beam).
imaging::VolumeF make_bmode(const Probe& probe, const imaging::LabelVolume& labels,
                            const BmodeOptions& options);

}  // namespace brainshift::data_synth
