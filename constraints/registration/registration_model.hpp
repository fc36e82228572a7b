#pragma once
/// @file
/// @brief The prepared registration model: K0 factorised, compliance block precomputed, features
/// mapped into the mesh, the rest surface indexed for dura contact and the model's response to
/// uniform loads. Built once before surgery and const from then on: a registration reads it and
/// never changes it (rotations are passed per step), so replay, bench and several registrations
/// share one model. Positions in mm, world (RAS) frame of the pre-operative images.

#include "constraints/registration/rows/constraint_builders.hpp"
#include "constraints/solver/constrained_step.hpp"
#include "core/geometry/skeleton.hpp"
#include "core/mapping/barycentric_mapping.hpp"
#include "core/mesh/tet_mesh.hpp"

#include <array>
#include <memory>
#include <vector>

namespace brainshift::constraints {

class FeatureIndex;

/// A model prepared once and reused across registrations (replay).
class RegistrationModel {
 public:
  /// @param[in] mesh rest mesh (validated). @param[in] fixed_nodes Dirichlet nodes (e.g. the
  /// cerebellum side); at least 3 non-collinear. @param[in] skeleton pre-operative vessel
  /// skeleton (rest positions, inside or ≤ 2 mm outside the mesh; may be empty).
  /// @param[in] surface collision surface (footprint and dura contact; may have no triangles).
  /// \throws brainshift::Error when K0 cannot be factorised or a feature point lies farther than
  /// 2 mm outside the mesh (naming it).
  RegistrationModel(const core::TetMesh& mesh, const std::vector<index_t>& fixed_nodes,
                    core::Skeleton skeleton, core::SurfaceMesh surface,
                    const ComplianceOptions& compliance = {});
  ~RegistrationModel();
  RegistrationModel(const RegistrationModel&) = delete;
  RegistrationModel& operator=(const RegistrationModel&) = delete;

  [[nodiscard]] const ConstrainedModel& mechanics() const { return *m_mechanics; }
  [[nodiscard]] const core::TetMesh& mesh() const { return m_mechanics->model().mesh(); }
  [[nodiscard]] const core::Skeleton& skeleton() const { return m_skeleton; }
  [[nodiscard]] const core::SurfaceMesh& surface() const { return m_surface; }
  [[nodiscard]] const core::BarycentricMapping& skeleton_mapping() const { return m_skeleton_map; }
  [[nodiscard]] const core::BarycentricMapping& surface_mapping() const { return m_surface_map; }
  /// Nearest-triangle index of the rest collision surface (the dura). Null without triangles.
  [[nodiscard]] const FeatureIndex* rest_surface_index() const { return m_rest_surface.get(); }
  /// Area-weighted unit vertex normals of the rest collision surface (#V×3).
  [[nodiscard]] const MatrixX3d& rest_surface_normals() const { return m_rest_normals; }
  /// Stencil (mesh nodes and weights) of skeleton point `i` / surface vertex `i`.
  [[nodiscard]] Stencil skeleton_stencil(index_t i) const;
  [[nodiscard]] Stencil surface_stencil(index_t i) const;
  /// Seconds spent preparing (factorisation, compliance block, mappings, load responses).
  [[nodiscard]] double seconds_prepare() const { return m_seconds_prepare; }
  /// Nodal displacements (#N×3 each, mm) of the linear model under a uniform body load along x,
  /// y and z: the shape of the bulk-shift search's basis. Computed up front by the constructor
  /// (three solves): it depends on the model only, not on the frame or the data.
  [[nodiscard]] const std::array<MatrixX3d, 3>& load_response() const { return m_load_response; }

 private:
  core::Skeleton m_skeleton;
  core::SurfaceMesh m_surface;
  core::BarycentricMapping m_skeleton_map;
  core::BarycentricMapping m_surface_map;
  std::unique_ptr<FeatureIndex> m_rest_surface;
  MatrixX3d m_rest_normals;
  std::unique_ptr<ConstrainedModel> m_mechanics;
  double m_seconds_prepare = 0.0;
  std::array<MatrixX3d, 3> m_load_response;
};

}  // namespace brainshift::constraints
