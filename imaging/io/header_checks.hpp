#pragma once
/// @file
/// @brief Checks of a volume file's header before its data are read or allocated: what the header
/// claims against a memory ceiling and against the file itself.

#include <string>

namespace brainshift::imaging {

/// The most bytes of voxel data a header may claim: the environment's BRAINSHIFT_MAX_VOLUME_GB
/// (GiB, default 4).
double max_volume_bytes();

/// \throws brainshift::Error naming `file` when the `claimed` bytes of voxel data exceed
/// max_volume_bytes(), or the file: raw data, the bytes after `offset`; compressed data,
/// deflate's largest ratio (1032:1) times the file's size.
void verify_claimed_bytes(const std::string& file, double claimed, double offset, bool compressed);

/// VTK XML (.vtu, .vtp, .vti): the sizes every `<Piece>` claims (NumberOfPoints, NumberOfCells,
/// NumberOfVerts/Lines/Strips/Polys) and an image's WholeExtent, before VTK allocates them: whole
/// numbers, what they would take in memory under max_volume_bytes(), and at least one byte per
/// value on disk (any encoding; deflate's 1032:1 for a compressed file). The header is read up to
/// the appended data (at most 1 MiB). \throws brainshift::Error, one line naming the file and the
/// attribute.
void verify_vtk_xml_header(const std::string& file);

/// MetaImage (.mha, .mhd): the text header's NDims (2 or 3), ElementNumberOfChannels (1 to 16)
/// and ElementDataFile (LOCAL or one file: no patterns, whose step 0 divided by zero in MetaIO, no
/// lists) before MetaIO parses it (MetaIO reads NDims² numbers for TransformMatrix: a huge NDims
/// hung it, NDims = 0 divided by zero — fuzzing). \throws brainshift::Error, one line naming the
/// file and the field.
void verify_metaimage_header(const std::string& file);

/// NIfTI-1 and NIfTI-2: the 348- or 540-byte header (through zlib for .nii.gz) — dimensions, the
/// scalar type and bitpix, the spacing (finite, non-zero), a single file's magic and the data it
/// claims — before VTK reads anything.
/// \throws brainshift::Error, one line naming the file and the field.
void verify_nifti_header(const std::string& file);

}  // namespace brainshift::imaging
