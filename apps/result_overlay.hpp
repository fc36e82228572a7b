#pragma once
/// @file
/// @brief RES/overlay.png of `register`: axial, coronal and sagittal slices through the centre of
/// the intra-operative vessel points — pre-operative MRI (left) and warped MRI (right) when an MRI
/// was given, else the displacement magnitude — with the intra-operative vessel points (green)
/// and footprint points (yellow) drawn in the intra-operative frame.

#include <filesystem>

#include "constraints/registration/registration.hpp"
#include "imaging/io/volume.hpp"

namespace brainshift::apps {

void write_result_overlay(const std::filesystem::path& path, const imaging::VolumeF* mri,
                          const imaging::VolumeF* warped, const imaging::VolumeF& displacement,
                          const constraints::IntraopData& data);

}  // namespace brainshift::apps
