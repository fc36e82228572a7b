#pragma once
/// @file
/// @brief The truth displacement as a field: the TLED nodal displacement of the truth mesh,
/// interpolated linearly (barycentric in the rest truth mesh) at any rest point X, giving the
/// forward map X ↦ x = X + u(X) (pre-operative → intra-operative, world RAS mm).

#include "core/config.hpp"
#include "core/mapping/tet_locator.hpp"
#include "core/mesh/tet_mesh.hpp"
#include "imaging/io/volume.hpp"

#include <optional>

namespace brainshift::data_synth {

/// u(X) on the rest truth mesh. Holds copies of the mesh nodes, tetrahedra and displacement.
class TruthField {
 public:
  /// @param[in] rest  the rest truth mesh (world RAS mm).
  /// @param[in] displacement  #N×3 nodal displacement, mm.
  /// @param[in] max_outside  points outside the mesh but within this distance (mm) take the
  /// value at their closest point of the nearest tetrahedron (the snapped truth mesh leaves
  /// slivers of the analytic brain outside it), ≥ 0.
  TruthField(const core::TetMesh& rest, MatrixX3d displacement, double max_outside = 4.0);

  /// u(X), mm, or std::nullopt when X is farther than max_outside from the mesh.
  [[nodiscard]] std::optional<Vector3d> try_displacement_at(const Vector3d& X) const;
  /// u(X), mm. \throws brainshift::Error naming X when it is farther than max_outside.
  [[nodiscard]] Vector3d displacement_at(const Vector3d& X) const;
  /// X + u(X), mm. \throws as displacement_at().
  [[nodiscard]] Vector3d deform(const Vector3d& X) const { return X + displacement_at(X); }

  [[nodiscard]] const MatrixX3d& rest_nodes() const { return m_rest; }
  [[nodiscard]] const MatrixX4i& tets() const { return m_tets; }
  [[nodiscard]] const MatrixX3d& nodal_displacement() const { return m_u; }
  /// Deformed node positions X + u, #N×3 mm.
  [[nodiscard]] MatrixX3d deformed_nodes() const { return m_rest + m_u; }

  /// u sampled at every voxel centre of `grid` (3 components, mm, RAS): barycentric inside the
  /// rest mesh, closest-point value within max_outside of it, 0 farther away.
  [[nodiscard]] imaging::VolumeF displacement_image(const imaging::ImageGeometry& grid) const;

 private:
  MatrixX3d m_rest;
  MatrixX4i m_tets;
  MatrixX3d m_u;
  double m_max_outside = 4.0;
  core::TetLocator m_locator;
};

}  // namespace brainshift::data_synth
