#pragma once
/// @file
/// @brief OpenIGTLink messages (the 58-byte header, version 1, of Debian's libopenigtlink 1.11)
/// to and from brainshift's types, with the checks a server needs before trusting a peer.
///
/// IMAGE geometry, as OpenIGTLink defines it (and Slicer's OpenIGTLinkIO and PLUS use it): the
/// matrix columns t, s, n are the world directions of the i, j, k axes with lengths equal to the
/// voxel spacing (mm), and the position p is the image's centre — the mean of the first and last
/// voxel centres: p = origin + D·diag(spacing)·(size − 1)/2. The header's coordinate field says
/// RAS (1) or LPS (2); brainshift works in world RAS and converts LPS images on reception.
/// TRANSFORM and POLYDATA are sent in world RAS, mm (Slicer's frame).

#include "core/config.hpp"
#include "imaging/io/volume.hpp"

#include <Eigen/Geometry>

#include <array>
#include <igtlImageMessage.h>
#include <igtlPolyDataMessage.h>
#include <igtlStatusMessage.h>
#include <igtlStringMessage.h>
#include <igtlTransformMessage.h>
#include <string>
#include <vector>

namespace brainshift::serve {

/// Bytes of an IMAGE body's own header (before the voxels).
inline constexpr std::uint64_t image_header_bytes = 72;

/// The voxels of a received, unpacked IMAGE message as a volume in world RAS (float voxels).
/// Accepted: one component of int8, uint8, int16, uint16, int32, uint32, float32 or float64,
/// either byte order, RAS or LPS, the whole image (no partial transfer), a matrix that is a
/// rotation (or reflection) times the spacing.
/// \throws brainshift::Error, one line naming `name` (the device) and what is wrong: another
/// scalar type or component count, a partial image, a body whose size does not match the
/// dimensions, a non-finite or zero spacing, a sheared or singular matrix.
imaging::VolumeF volume_from_image(igtl::ImageMessage& message, std::uint64_t body_bytes,
                                   const std::string& name);

/// A float32 IMAGE message of `volume` (one component; world RAS, little-endian), ready to send.
igtl::ImageMessage::Pointer image_message(const imaging::VolumeF& volume,
                                          const std::string& device);

/// A TRANSFORM message of a rigid transform (world RAS, mm), ready to send.
igtl::TransformMessage::Pointer transform_message(const Eigen::Isometry3d& transform,
                                                  const std::string& device);

/// A STATUS message, ready to send: `code` one of igtl::StatusMessage's (STATUS_OK, ...),
/// `subcode` (a percentage for progress), `error_name` (≤ 20 characters), `text`.
igtl::StatusMessage::Pointer status_message(int code, long long subcode,
                                            const std::string& error_name, const std::string& text,
                                            const std::string& device);

/// A STRING message (UTF-8 text), ready to send.
igtl::StringMessage::Pointer string_message(const std::string& text, const std::string& device);

/// A POLYDATA message of polylines: `points` (#P×3, world RAS mm) joined by `segments`
/// (consecutive segments sharing a point become one line).
igtl::PolyDataMessage::Pointer lines_message(const MatrixX3d& points,
                                             const std::vector<std::array<index_t, 2>>& segments,
                                             const std::string& device);

/// A POLYDATA message of a triangle surface: `points` (#P×3, world RAS mm), `triangles` (#F×3).
igtl::PolyDataMessage::Pointer surface_message(
    const MatrixX3d& points, const Eigen::Matrix<index_t, Eigen::Dynamic, 3, Eigen::RowMajor>& tri,
    const std::string& device);

}  // namespace brainshift::serve
