#pragma once
/// @file
/// @brief Reading and writing voxel volumes in world RAS millimetres (see volume.hpp), whatever
/// the frame of the file. The format follows the file name:
///
/// | extension        | format     | frame of the file | read / write                         |
/// |------------------|------------|-------------------|--------------------------------------|
/// | .nii, .nii.gz    | NIfTI-1    | RAS (sform/qform) | VTK's header; voxels nifti_voxels.hpp|
/// | .mha, .mhd       | MetaImage  | LPS (ITK physical)| VTK's metaio; writes .mha only       |
/// | .nrrd            | NRRD       | its `space` field | nrrd_io.hpp (writes RAS)             |
/// | .vti             | VTK XML    | RAS (our choice)  | vtkXMLImageDataReader/Writer         |
/// | folder, .dcm     | DICOM      | LPS (patient)     | dicom_io.hpp (GDCM); read only here  |
///
/// NIfTI: the world is the sform when sform_code > 0, else the qform when qform_code > 0, else
/// (method 1) the pixel spacing about the origin, with a warning. scl_slope/scl_inter are
/// applied. Written with the same matrix as sform (code 2, aligned) and qform (code 1, scanner).
///
/// MetaImage: physical point = Offset + D·diag(ElementSpacing)·ijk in LPS, as ITK and 3D Slicer
/// read it, where column a of D is TransformMatrix values 3a…3a+2 (ITK's MetaImageIO order);
/// converted to RAS by negating x and y. AnatomicalOrientation describes the axes, not the
/// world frame, and is ignored (as in ITK).
///
/// Vector volumes: a volume with 3 components is a vector field (e.g. a displacement, mm)
/// expressed in the world frame of its file: LPS files (MetaImage, NRRD in LPS) get their x and
/// y components negated on reading and on writing, like the geometry. Other component counts
/// are copied as they are.

#include "imaging/io/volume.hpp"

#include <filesystem>
#include <string>

namespace brainshift::imaging {

/// Volume file formats, chosen by file extension.
enum class ImageFormat { NIFTI, METAIMAGE, NRRD, VTI };

/// The format of `path` from its extension (case-insensitive).
/// \throws brainshift::Error naming the file and the supported extensions when unknown.
ImageFormat image_format(const std::filesystem::path& path);

/// Reads a volume (any voxel type, converted to float) into world RAS, mm. A direction matrix
/// orthonormal only to single precision (|DᵀD − I| ≤ 1e-4, image_frame.hpp) is replaced by the
/// nearest orthonormal one; a real shear or a singular matrix is an error.
/// @param[out] header_note  when not null: a one-line note naming the file when the header was
/// mended beyond float rounding (orthonormalise_direction()), else empty. Also logged.
/// @return the volume; `components` ≥ 1 values per voxel.
/// \throws brainshift::Error, one line naming the file and the problem: missing file, unknown
/// extension, corrupt or truncated data, zero size, non-finite or non-positive spacing,
/// non-finite, singular or sheared direction.
VolumeF read_volume(const std::filesystem::path& path, std::string* header_note = nullptr);

/// read_volume() of a NIfTI file (.nii, .nii.gz) with its voxels read and copied by VTK's
/// reader, as read_volume() did before it read them directly (nifti_voxels.hpp): the reference
/// the tests compare the direct read with. \throws brainshift::Error as read_volume().
VolumeF read_nifti_by_vtk(const std::filesystem::path& path);

/// Reads a label volume: one component, every value in {0, 1, 2, 3} (see Label).
/// \throws brainshift::Error as read_volume(), and naming the first other value and its voxel.
LabelVolume read_labels(const std::filesystem::path& path);

/// Writes a float volume (world RAS) atomically (write_atomically()): nothing half-written is
/// left under `path`. MetaImage is written as compressed .mha; .mhd is refused.
/// \throws brainshift::Error naming the path: unknown extension, missing folder, empty volume,
/// inconsistent data size, or a failed write.
void write_volume(const std::filesystem::path& path, const VolumeF& volume);

/// Writes a one-component label volume as unsigned 8-bit voxels, atomically.
/// \throws brainshift::Error as write_volume(), and when a value is not a Label.
void write_labels(const std::filesystem::path& path, const LabelVolume& labels);

/// Writes a displacement field for 3D Slicer, which loads it as a grid transform (Add Data →
/// Transform): a NRRD file (.nrrd) in `space: left-posterior-superior`, float32, axis kinds
/// `vector domain domain domain`, raw encoding. Slicer (through ITK) reads geometry and vectors in
/// LPS, so both are converted: space origin and space directions get x and y negated, and so
/// does each vector, u_LPS = (−u_x, −u_y, u_z)_RAS.
///
/// Slicer treats a displacement field like ITK, as a resampling ("from parent") transform: for
/// a point p of the grid, p + u(p) is the corresponding point of the transformed space. Pass the
/// field in that sense; the file says so (`intent_code:=1006`, `displacement field
/// type:=resampling`, identity measurement frame).
/// @param[in] path  target, must end in .nrrd.
/// @param[in] displacement_ras  3 components per voxel, mm, world RAS vectors on a RAS grid.
/// \throws brainshift::Error naming the path: not .nrrd, not 3 components, non-finite values,
/// or a failed write.
void write_displacement_for_slicer(const std::filesystem::path& path,
                                   const VolumeF& displacement_ras);

}  // namespace brainshift::imaging
