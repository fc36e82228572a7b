#include "constraints/registration/registration_model.hpp"

#include "constraints/registration/pairing/pairing.hpp"

#include <chrono>
#include <set>

namespace brainshift::constraints {
namespace {

std::vector<index_t> block_nodes_of(const core::TetMesh& mesh, const core::BarycentricMapping& a,
                                    const core::BarycentricMapping& b) {
  std::set<index_t> nodes;
  for (const auto* m : {&a, &b})
    for (index_t t : m->tet())
      for (int k = 0; k < 4; ++k) nodes.insert(mesh.tets()(t, k));
  return {nodes.begin(), nodes.end()};
}

}  // namespace

RegistrationModel::RegistrationModel(const core::TetMesh& mesh,
                                     const std::vector<index_t>& fixed_nodes,
                                     core::Skeleton skeleton, core::SurfaceMesh surface,
                                     const ComplianceOptions& compliance)
    : m_skeleton(std::move(skeleton)), m_surface(std::move(surface)) {
  const auto t0 = std::chrono::steady_clock::now();
  m_skeleton_map = core::BarycentricMapping(mesh, m_skeleton.points);
  m_surface_map = core::BarycentricMapping(mesh, m_surface.vertices);
  if (m_surface.triangles.rows() > 0)
    m_rest_surface = std::make_unique<FeatureIndex>(
        FeatureIndex::triangles(m_surface.vertices, m_surface.triangles));
  m_rest_normals = vertex_normals(m_surface);
  m_mechanics = std::make_unique<ConstrainedModel>(
      mesh, fixed_nodes, block_nodes_of(mesh, m_skeleton_map, m_surface_map), compliance);
  const core::TetMesh& rest = m_mechanics->model().mesh();
  StepOptions o;
  o.mechanics = Mechanics::LINEAR;
  for (int k = 0; k < 3; ++k) {
    o.gravity = 9810.0 * Vector3d::Unit(k);
    m_load_response[static_cast<std::size_t>(k)] =
        m_mechanics->step(rest.nodes(), ConstraintRows{}, o).x - rest.nodes();
  }
  m_seconds_prepare = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

RegistrationModel::~RegistrationModel() = default;

Stencil RegistrationModel::skeleton_stencil(index_t i) const {
  return MappedVertices{&mesh(), &m_skeleton_map}.stencil(i);
}
Stencil RegistrationModel::surface_stencil(index_t i) const {
  return MappedVertices{&mesh(), &m_surface_map}.stencil(i);
}

}  // namespace brainshift::constraints
