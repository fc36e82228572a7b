#pragma once
/// @file
/// @brief Generation of a complete phantom case with its truth, written to a folder:
///
///     DIR/case.json                              parameters, seed, shift statistics, timings
///     DIR/preop/{mri,labels,mra}.nii.gz          pre-operative images (world RAS mm)
///     DIR/preop/vessels.vtp                      the true pre-operative vessel tree
///     DIR/intraop/{doppler,bmode}.nii.gz         probe volumes in the deformed space
///     DIR/truth/displacement.nii.gz              u(X), 3 components, mm RAS, pre-op grid
///     DIR/truth/landmarks_{preop,intraop}.csv    id,x,y,z (mm RAS), same ids (intraop and the
///                                                ventricles in the images' frame for cases with
///                                                truth_in_image_frame, e.g. offset_12mm)
///     DIR/truth/ventricles_{preop,intraop}.vtp   ventricle surface of the truth mesh
///     DIR/intraop/frame_NNN/{doppler,bmode}.nii.gz, landmarks_intraop.csv   (with frames > 0)
///
/// The truth is the neo-Hookean TLED sag solve (truth/), never the registration code. The
/// intra-operative positions of points (vessels, landmarks, ventricle vertices) are X + u(X) with
/// u interpolated in the rest truth mesh. The folder appears complete or not at all: everything
/// is written into DIR.tmp-NNNN next to DIR, which is then renamed.

#include "data_synth/cases/case_catalog.hpp"

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace brainshift::data_synth {

struct CaseOptions {
  std::filesystem::path out;  ///< DIR: must not exist, or be an empty folder
  /// Sequence of K frames as the CSF keeps draining (drain depth k/K of the case's, k = 1..K);
  /// 0: no frames folder.
  int frames = 0;
  /// A user vessel tree (.vtp polylines, optional radius array) placed into the phantom instead
  /// of the synthetic trees.
  std::optional<std::filesystem::path> user_vessels;
  /// Called with one-line progress messages (may be empty).
  std::function<void(const std::string&)> progress;
};

/// Shift statistics of one deformed state, mm.
struct ShiftStats {
  double max_cortical_shift = 0.0;   ///< max |u| over the truth mesh's (non-base) surface nodes
  double mean_cortical_shift = 0.0;  ///< mean |u| over surface nodes under the craniotomy
  double mean_landmark_shift = 0.0;  ///< mean |x − X| over the landmarks
  double max_landmark_shift = 0.0;
};

struct CaseSummary {
  std::string name;
  std::uint32_t seed = 0;
  ShiftStats stats;                ///< of the final (full-load) state
  std::vector<ShiftStats> frames;  ///< per frame, when frames > 0
  TledStatus solver_status = TledStatus::DIVERGED;
  std::string solver_message;
  index_t landmarks = 0;  ///< how many (vessel bifurcations in the field of view + deep)
  index_t vessel_landmarks = 0;
  index_t vessel_points = 0;
  double seconds = 0.0;  ///< wall time of the whole generation
};

/// Generates the named case for `seed` into options.out.
/// \throws brainshift::Error on an unknown name (listing the valid ones), an existing non-empty
/// DIR, an unreadable user tree, or a diverged truth solve; nothing is left under DIR then.
CaseSummary generate_case(const std::string& name, std::uint32_t seed, const CaseOptions& options);

/// Generates a case from explicit parameters (see named_case()).
CaseSummary generate_case(const CaseParameters& parameters, const CaseOptions& options);

struct CaseAnatomy;  // case_anatomy.hpp

/// Generates a case from explicit parameters on a given anatomy (analytic_anatomy(), or a label
/// volume's: label_case.hpp); parameters.geometry is not used then.
CaseSummary generate_case(const CaseParameters& parameters, const CaseAnatomy& anatomy,
                          const CaseOptions& options);

/// The checks of generate_case on the options alone (output folder new or empty, its parent
/// present, frames ≥ 0, the user tree exists), before anything is computed or written.
/// \throws brainshift::Error, one line.
void check_case_options(const CaseOptions& options);

/// The label volume of a case: the phantom's, plus the thin structures when asked for.
imaging::LabelVolume case_labels(const CaseParameters& parameters);

}  // namespace brainshift::data_synth
