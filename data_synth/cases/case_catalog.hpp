#pragma once
/// @file
/// @brief The named phantom cases: every parameter of a case (geometry, truth mesh and load,
/// vessels, images, probe, tracking error), deterministic from the name and a seed.
///
/// | name                          | what it stresses                                           |
/// |-------------------------------|------------------------------------------------------------|
/// | standard                      | superficial tumour, CSF drained to 60 mm, 5–15 mm shift    |
/// | large_shift                   | soft brain, fully drained, tilted gravity: ≥ 20 mm shift   |
/// | deep_tumour_one_side_vessels  | deep tumour, cortical vessels on one side of the opening   |
/// | noisy_doppler                 | 40 % dropout, strong speckle, many spurious blobs          |
/// | tracking_error                | probe pose off by 3 mm and 3° in the intra-operative headers|
/// | sparse_vessels                | one small cortical tree, no deep branches                  |
/// | resection                     | tumour removed: a soft compressible cavity that collapses  |
/// | thin_structures               | a thin ventricle horn and a one-voxel sulcus in the labels |
/// | offset_12mm                   | standard seen through a 12 mm / 3° tracking offset         |
/// | offset_20mm                   | standard seen through a 20 mm / 4° tracking offset         |
/// | sparse_offset_12mm            | sparse_vessels seen through offset_12mm's offset           |

#include "data_synth/geometry/brain_phantom.hpp"
#include "data_synth/geometry/phantom_mesh.hpp"
#include "data_synth/images/preop_images.hpp"
#include "data_synth/images/probe.hpp"
#include "data_synth/images/ultrasound_images.hpp"
#include "data_synth/truth/brain_sag.hpp"
#include "data_synth/truth/tled_solver.hpp"
#include "data_synth/vessels/vessel_tree.hpp"

#include <cstdint>
#include <string>
#include <vector>

namespace brainshift::data_synth {

/// Everything that defines a case.
struct CaseParameters {
  std::string name;
  std::uint32_t seed = 1;
  PhantomGeometry geometry;
  double preop_spacing = 1.0;  ///< pre-operative voxel size (labels, MRI, MRA, truth field), mm
  PhantomMeshOptions mesh;     ///< the truth mesh (cell size 5.5 mm by default)
  SagLoad load;
  TledOptions tled;
  /// Resection: tumour elements get cavity_youngs_modulus and cavity_poisson_ratio (a drained,
  /// compressible cavity) and render as fluid intra-operatively.
  bool resection = false;
  double cavity_youngs_modulus = 0.15;  ///< kPa (softer ones invert elements in the TLED solve)
  double cavity_poisson_ratio = 0.3;
  /// Thin structures in the pre-operative labels (not in the truth mechanics, whose mesh cannot
  /// resolve them): a ventricle horn of radius horn_radius and a one-voxel sulcus.
  bool thin_structures = false;
  double horn_radius = 1.2;    ///< mm
  double sulcus_depth = 15.0;  ///< mm
  VesselTreeOptions vessels;
  MriOptions mri;
  MraOptions mra;
  ProbeOptions probe;
  double probe_indent = 1.0;  ///< the probe face presses this far into the deformed brain, mm
  DopplerOptions doppler;
  BmodeOptions bmode;
  TrackingError tracking;
  /// Where the intra-operative truth (landmarks, ventricle surface) is written. false: the true
  /// world frame — `tracking` is an error of the probe's tracking that no registration to the
  /// images can see (tracking_error). true: the frame of the intra-operative images, as an expert
  /// marks landmarks in the ultrasound (RESECT) — `tracking` is then an offset between the
  /// pre-operative images and the navigation, which the registration must recover (offset_*).
  bool truth_in_image_frame = false;
  /// The tracking accuracy the case declares, as a site states its tracker's and probe
  /// calibration's (the predicted error's uncertainty.tracking_*: RMS translation, mm; RMS
  /// rotation, degrees): the spec of an error of the data's frame that the images cannot show.
  /// Not a distribution the phantom draws from (`tracking` is fixed): the size the table above
  /// declares, "off by 3 mm and 3°", on tracking_error; 0 where the offset is the registration's
  /// to recover (truth_in_image_frame) and without one.
  double tracking_spec_translation_mm = 0.0;
  double tracking_spec_rotation_deg = 0.0;
  double deep_landmark_offset = 5.0;  ///< deep landmarks lie this far outside the tumour, mm
};

/// Names of the cases, in the order of the table above.
std::vector<std::string> case_names();

/// The parameters of a named case for a seed (the seed drives the vessels and all noise).
/// \throws brainshift::Error "unknown phantom case 'x' (valid: standard, …)" for other names.
CaseParameters named_case(const std::string& name, std::uint32_t seed);

}  // namespace brainshift::data_synth
