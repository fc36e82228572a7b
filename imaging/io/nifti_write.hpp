#pragma once
/// @file
/// @brief NIfTI-1 files byte for byte as vtkNIFTIImageWriter writes them (qform and sform the
/// volume's world matrix in RAS mm, image origin 0, no rescaling), built here and streamed in
/// blocks: no vtkImageData copy, no temporary .nii re-read, no copy of the whole file in memory.

#include "imaging/io/volume.hpp"

#include <filesystem>

namespace brainshift::imaging {

/// Writes `volume` to `temporary` (gzipped when `gz`) as VTK's writer would for `target`; false,
/// with nothing written, for the layouts VTK treats specially (2 components, unsigned char with
/// 3 or 4, an axis longer than 32767), which the caller writes through VTK itself.
/// \throws brainshift::Error naming `target` when the file cannot be written.
template <typename T>
bool write_nifti_as_vtk(const std::filesystem::path& target, const std::filesystem::path& temporary,
                        const Volume<T>& volume, bool gz);

}  // namespace brainshift::imaging
