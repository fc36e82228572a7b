#pragma once
/// @file
/// @brief Frame conversions shared by the image readers and writers: LPS ("ITK", DICOM) ↔ RAS
/// (NIfTI, brainshift world), and the geometry checks every reader applies.
///
/// LPS and RAS differ by a half-turn about the superior axis: (x, y, z)_RAS = (−x, −y, z)_LPS,
/// the same map both ways (it is its own inverse).

#include <string>

#include "imaging/io/volume.hpp"

namespace brainshift::imaging {

/// diag(−1, −1, 1): LPS ↔ RAS for points and vectors.
[[nodiscard]] inline Matrix3d lps_ras_flip() { return Vector3d(-1.0, -1.0, 1.0).asDiagonal(); }

/// The same grid expressed in the other frame (LPS ↔ RAS): origin and direction columns flipped.
[[nodiscard]] ImageGeometry flip_lps_ras(const ImageGeometry& geometry);

/// Flips the x and y components of a 3-component (vector) volume in place (LPS ↔ RAS vectors);
/// volumes with another number of components are left as they are.
void flip_vectors_lps_ras(Volume<float>& volume);

/// Checks a geometry read from `file`: at least one voxel along each axis, finite positive
/// spacing, finite origin, a finite orthonormal direction (columns of unit length, mutually
/// orthogonal within 1e-3, as stored in float headers).
/// \throws brainshift::Error, one line naming `file` and the offending value.
void verify_geometry(const ImageGeometry& geometry, const std::string& file);

}  // namespace brainshift::imaging
