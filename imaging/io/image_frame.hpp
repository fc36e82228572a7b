#pragma once
/// @file
/// @brief Frame conversions shared by the image readers and writers: LPS ("ITK", DICOM) ↔ RAS
/// (NIfTI, brainshift world), and the geometry checks every reader applies.
///
/// LPS and RAS differ by a half-turn about the superior axis: (x, y, z)_RAS = (−x, −y, z)_LPS,
/// the same map both ways (it is its own inverse).

#include "imaging/io/volume.hpp"

#include <string>

namespace brainshift::imaging {

/// diag(−1, −1, 1): LPS ↔ RAS for points and vectors.
[[nodiscard]] inline Matrix3d lps_ras_flip() { return Vector3d(-1.0, -1.0, 1.0).asDiagonal(); }

/// The same grid expressed in the other frame (LPS ↔ RAS): origin and direction columns flipped.
[[nodiscard]] ImageGeometry flip_lps_ras(const ImageGeometry& geometry);

/// Flips the x and y components of a 3-component (vector) volume in place (LPS ↔ RAS vectors);
/// volumes with another number of components are left as they are.
void flip_vectors_lps_ras(Volume<float>& volume);

/// Largest |DᵀD − I| accepted as orthonormal: single-precision headers (NIfTI sform, VTK, NRRD
/// written from floats) hold a rotation to ~1e-6; 1e-4 leaves room for a few rounding steps and
/// stays far below any real shear (1e-2 is 0.6°).
inline constexpr double direction_orthonormal_tolerance = 1e-4;

/// Above this |DᵀD − I| a direction is more than float rounding away from orthonormal, and
/// orthonormalise_direction() says so in its note (below it, it is mended silently).
inline constexpr double direction_note_level = 1e-6;

/// |DᵀD − I| (largest entry), 0 for an exactly orthonormal matrix.
[[nodiscard]] double orthonormality_error(const Matrix3d& direction);

/// Checks a geometry read from `file`: at least one voxel along each axis, finite positive
/// spacing, finite origin, a finite direction, orthonormal within
/// direction_orthonormal_tolerance (a singular or sheared matrix is an error).
/// \throws brainshift::Error, one line naming `file` and the offending value.
void verify_geometry(const ImageGeometry& geometry, const std::string& file);

/// Replaces a nearly orthonormal direction by the nearest orthonormal matrix (polar factor
/// U·Vᵀ of its SVD D = U·Σ·Vᵀ; keeps the handedness), so every later step sees an exact rotation
/// or reflection. Call after verify_geometry().
/// @param[in,out] geometry  its direction is replaced.
/// @param[in] file  named in the note.
/// @return a one-line note naming `file` and |DᵀD − I| when that exceeded direction_note_level
/// (the header was mended, not only rounded), else an empty string.
std::string orthonormalise_direction(ImageGeometry& geometry, const std::string& file);

}  // namespace brainshift::imaging
