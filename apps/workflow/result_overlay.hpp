#pragma once
/// @file
/// @brief RES/overlay.png of `register`: axial, coronal and sagittal slices through the centre of
/// the intra-operative vessel points — pre-operative MRI (left) and warped MRI (right) when an MRI
/// was given, else the displacement magnitude (left) and the predicted error (right) —
/// with the intra-operative vessel points (green) and footprint points (yellow) drawn in the
/// intra-operative frame. With an MRI the predicted-error panels go to RES/overlay_uncertainty.png
/// (displacement magnitude and predicted error), so the MRI comparison keeps its two columns.

#include "constraints/registration/registration.hpp"
#include "imaging/io/volume.hpp"

#include <filesystem>

namespace brainshift::workflow {

/// @param[in] uncertainty the predicted-error map (mm, one component) or null (no panel).
void write_result_overlay(const std::filesystem::path& path, const imaging::VolumeF* mri,
                          const imaging::VolumeF* warped, const imaging::VolumeF& displacement,
                          const constraints::IntraopData& data,
                          const imaging::VolumeF* uncertainty = nullptr);

}  // namespace brainshift::workflow
