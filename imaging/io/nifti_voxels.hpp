#pragma once
/// @file
/// @brief The voxels of a single-file NIfTI (.nii, .nii.gz) read straight into float: the file
/// read once, inflated by ISA-L's igzip where the build has it (zlib otherwise) directly into the
/// volume's buffer. VTK's reader inflates with zlib's gzread into a buffer of its own that is
/// then copied; on the 16 M-voxel Doppler of `register` that was about a third of the critical
/// path's extraction (docs/BENCHMARKS.md, "Extraction and imaging"). image_io.cpp reads the
/// header and the geometry with VTK as before and uses this for the voxels of the files it
/// covers; it reads the same values (tests/imaging/io/test_image_io.cpp compares both on every
/// NIfTI of ../shared/data).

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <vector>

namespace brainshift::imaging {

/// Where the voxels lie in the (inflated) file and what they are.
struct NiftiVoxelLayout {
  std::int64_t offset = 352;  ///< vox_offset, bytes from the start of the inflated file
  int datatype = 16;          ///< NIfTI datatype code (2 uint8, 4 int16, 16 float32, …)
  std::size_t count = 0;      ///< voxels (one component each)
};

/// True for the datatypes read_nifti_voxels() reads: the integer types of 8-32 bits, float32 and
/// float64.
bool nifti_voxels_readable(int datatype);

/// Reads layout.count voxels into `out` (float; integers and doubles converted as VTK's reader
/// and static_cast<float> do). Returns false, with `out` untouched, where the file is not one it
/// reads: a datatype nifti_voxels_readable() refuses, voxels more than 1 MiB into the file (a
/// header's extensions, or a corrupt vox_offset), or a header in the other byte order (the
/// caller then reads it with VTK).
/// \throws brainshift::Error naming the file when it cannot be read, is not a valid gzip stream,
/// or ends before its voxels (truncated).
bool read_nifti_voxels(const std::filesystem::path& path, const NiftiVoxelLayout& layout,
                       std::vector<float>& out);

}  // namespace brainshift::imaging
