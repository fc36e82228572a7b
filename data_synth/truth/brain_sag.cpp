#include "data_synth/truth/brain_sag.hpp"

#include "core/error.hpp"

#include <sstream>

namespace brainshift::data_synth {

std::string SagLoad::validate() const {
  std::ostringstream s;
  if (!(gravity_direction.allFinite() && gravity_direction.norm() > 0.0))
    s << "gravity_direction must be finite and non-zero";
  else if (!(gravity >= 0.0))
    s << "gravity must be >= 0, got " << gravity << " mm/s^2";
  else if (!(csf_density >= 0.0 && brain_density >= 0.0))
    s << "densities must be >= 0";
  else if (!(drain_depth >= 0.0))
    s << "drain_depth must be >= 0, got " << drain_depth << " mm";
  else if (!(load_scale >= 0.0))
    s << "load_scale must be >= 0, got " << load_scale;
  return s.str();
}

MatrixX3d sag_nodal_force(const core::TetMesh& mesh, const SagLoad& load) {
  const std::string bad = load.validate();
  BS_VERIFY(bad.empty(), "invalid sag load: " << bad);
  const Vector3d g = load.gravity * load.gravity_direction.normalized();  // mm/s²
  const index_t n = mesh.num_nodes();
  Eigen::VectorXd nodal_volume = Eigen::VectorXd::Zero(n);
  for (index_t t = 0; t < mesh.num_tets(); ++t)
    for (int a = 0; a < 4; ++a) nodal_volume(mesh.tets()(t, a)) += 0.25 * mesh.signed_volume(t);
  const Eigen::VectorXd height = -(mesh.nodes() * g.normalized());  // along "up", mm
  const double surface = height.maxCoeff() - load.drain_depth;
  MatrixX3d f = MatrixX3d::Zero(n, 3);
  for (index_t i = 0; i < n; ++i) {
    double density = load.include_preoperative_weight ? load.brain_density - load.csf_density : 0.0;
    if (height(i) >= surface) density += load.csf_density;
    f.row(i) = (load.load_scale * density * nodal_volume(i) * g).transpose();
  }
  return f;
}

TledProblem make_sag_problem(const PhantomGeometry& geometry, const PhantomMesh& mesh,
                             const SagLoad& load) {
  TledProblem p;
  p.external_force = sag_nodal_force(mesh.mesh, load);
  for (const index_t i : mesh.base_nodes)
    p.constraints.push_back({i, {true, true, true}, Vector3d::Zero()});
  SkullContact contact;
  contact.skull = geometry.skull();
  contact.opening_centre = geometry.craniotomy_centre_on_skull();
  contact.opening_radius = geometry.craniotomy_radius;
  contact.candidate_nodes = mesh.surface_nodes;
  p.contact = contact;
  return p;
}

}  // namespace brainshift::data_synth
