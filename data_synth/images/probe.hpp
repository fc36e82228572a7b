#pragma once
/// @file
/// @brief The tracked intra-operative ultrasound probe of the phantom: its pose on the deformed
/// brain surface under the craniotomy, its field of view (a truncated cone: radius
/// footprint_radius at the probe face, opening with half_angle_deg down to `depth`), the voxel
/// grid of its volumes (axes along the probe frame, so the world header carries a rotation), and
/// an optional rigid tracking error applied to that header.

#include "core/config.hpp"
#include "imaging/io/volume.hpp"

#include <string>

namespace brainshift::data_synth {

struct ProbeOptions {
  double half_angle_deg = 40.0;    ///< half opening angle of the sector, degrees, in (0, 80)
  double depth = 60.0;             ///< field-of-view depth below the probe face, mm, > 0
  double footprint_radius = 15.0;  ///< radius of the probe face (contact disc), mm, > 0
  double spacing = 0.8;            ///< isotropic voxel size of the volumes, mm, > 0
  [[nodiscard]] std::string validate() const;
};

/// A probe pose (world RAS mm): the centre of its face and its frame.
struct Probe {
  Vector3d face_centre = Vector3d::Zero();
  Matrix3d frame = Matrix3d::Identity();  ///< columns: lateral 1, lateral 2, axis (into tissue)
  ProbeOptions options;

  /// Distance below the face along the axis, mm (negative above it).
  [[nodiscard]] double depth_of(const Vector3d& p) const {
    return (p - face_centre).dot(frame.col(2));
  }
  /// True inside the truncated cone of the field of view.
  [[nodiscard]] bool in_field_of_view(const Vector3d& p) const;
  /// The volume grid: axes = frame, covering the field of view, isotropic `spacing`.
  [[nodiscard]] imaging::ImageGeometry grid() const;
};

/// The probe at `face_centre` looking along `axis` (into the tissue, any length > 0).
/// \throws brainshift::Error on invalid options or a zero axis.
Probe make_probe(const Vector3d& face_centre, const Vector3d& axis, const ProbeOptions& options);

/// Rigid error of the probe tracking: the reported pose is the true one moved by
/// x ↦ R (x − c) + c + t, with c the probe face centre, R = Rz(γ) Ry(β) Rx(α) for
/// rotation_deg = (α, β, γ) about the world R, A, S axes, and t = translation.
struct TrackingError {
  Vector3d translation = Vector3d::Zero();   ///< mm, world RAS
  Vector3d rotation_deg = Vector3d::Zero();  ///< degrees about R, A, S through the face centre
  [[nodiscard]] bool is_zero() const { return translation.isZero() && rotation_deg.isZero(); }
  /// The rigid map applied to a world point p, mm.
  [[nodiscard]] Vector3d apply(const Vector3d& p, const Vector3d& pivot) const;
};

/// The header that the navigation would write for an image acquired on `grid` (true pose) when
/// the tracking is off by `error`: the content stays, the grid's world placement moves.
imaging::ImageGeometry with_tracking_error(const imaging::ImageGeometry& grid, const Probe& probe,
                                           const TrackingError& error);
/// The same with the error's rotation about `pivot` (world RAS mm) instead of the probe's face
/// centre: one navigation offset shared by sweeps made at different probe positions.
imaging::ImageGeometry with_tracking_error(const imaging::ImageGeometry& grid,
                                           const Vector3d& pivot, const TrackingError& error);

}  // namespace brainshift::data_synth
