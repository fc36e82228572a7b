#include "constraints/registration/rows/constraint_builders.hpp"

#include "core/error.hpp"

namespace brainshift::constraints {

Stencil MappedVertices::stencil(index_t i) const {
  Stencil s;
  const index_t t = tet(i);
  for (int k = 0; k < 4; ++k)
    if (map->weights()(i, k) != 0.0) s.add(mesh->tets()(t, k), map->weights()(i, k));
  return s;
}

std::string DuraOptions::validate() const {
  if (!craniotomy_centre.allFinite()) return "dura: craniotomy centre is not finite";
  if (!(craniotomy_radius_mm >= 0)) return "dura: craniotomy radius must be ≥ 0 mm";
  if (!(max_distance_mm > 0)) return "dura: max_distance_mm must be > 0";
  return {};
}

std::string to_string(DuraOptions::Mode mode) {
  return core::enum_to_string(mode);  // the option table's names (visit_fields)
}

void add_vessel_rows(ConstraintRows& rows, const std::vector<Pair>& pairs,
                     const core::Skeleton& skeleton, const MappedVertices& mapped,
                     ConstRef<MatrixX3d> x, ConstRef<MatrixX3d> points) {
  for (const Pair& p : pairs) {
    const auto& seg = skeleton.segments[static_cast<std::size_t>(p.feature)];
    const Stencil s =
        Stencil::interpolate(mapped.stencil(seg[0]), mapped.stencil(seg[1]), p.weights[1]);
    rows.add_sliding_line(s, x, points.row(p.point).transpose(), p.direction,
                          ConstraintSet::VESSELS, p.feature);
  }
}

void add_footprint_rows(ConstraintRows& rows, const std::vector<Pair>& pairs,
                        const core::SurfaceMesh& surface, const MappedVertices& mapped,
                        ConstRef<MatrixX3d> x, ConstRef<MatrixX3d> points,
                        ConstRef<MatrixX3d> normals) {
  for (const Pair& p : pairs) {
    const auto tri = surface.triangles.row(p.feature);
    const Stencil s = Stencil::combine(mapped.stencil(tri[0]), mapped.stencil(tri[1]),
                                       mapped.stencil(tri[2]), p.weights);
    const Vector3d n =
        normals.rows() > 0 ? Vector3d(normals.row(p.point).transpose()) : Vector3d(-p.direction);
    rows.add_unilateral_plane(s, x, points.row(p.point).transpose(), n, ConstraintSet::FOOTPRINT,
                              p.feature);
  }
}

MatrixX3d vertex_normals(const core::SurfaceMesh& surface) {
  MatrixX3d n = MatrixX3d::Zero(surface.vertices.rows(), 3);
  for (Eigen::Index f = 0; f < surface.triangles.rows(); ++f) {
    const auto t = surface.triangles.row(f);
    const Vector3d a = surface.vertices.row(t[0]).transpose(),
                   b = surface.vertices.row(t[1]).transpose(),
                   c = surface.vertices.row(t[2]).transpose();
    const Vector3d area_normal = 0.5 * (b - a).cross(c - a);
    for (int k = 0; k < 3; ++k) n.row(t[k]) += area_normal.transpose();
  }
  for (Eigen::Index v = 0; v < n.rows(); ++v)
    if (const double len = n.row(v).norm(); len > 0) n.row(v) /= len;
  return n;
}

index_t add_dura_rows(ConstraintRows& rows, const DuraOptions& options,
                      const core::SurfaceMesh& surface, const FeatureIndex& rest_index,
                      ConstRef<MatrixX3d> rest_normals, const MappedVertices& mapped,
                      ConstRef<MatrixX3d> x, const std::vector<bool>& skip) {
  if (options.mode == DuraOptions::Mode::NONE) return 0;
  const index_t before = rows.size();
  for (index_t v = 0; v < surface.vertices.rows(); ++v) {
    if (!skip.empty() && skip[static_cast<std::size_t>(v)]) continue;
    const Vector3d rest = surface.vertices.row(v).transpose();
    if ((rest - options.craniotomy_centre).norm() < options.craniotomy_radius_mm) continue;
    const Stencil s = mapped.stencil(v);
    const auto pair = rest_index.nearest(s.position(x), options.max_distance_mm);
    if (!pair) continue;
    const auto tri = surface.triangles.row(pair->feature);
    Vector3d outward = Vector3d::Zero();
    for (int k = 0; k < 3; ++k) outward += pair->weights[k] * rest_normals.row(tri[k]).transpose();
    outward = outward.norm() > 1e-12 ? Vector3d(outward.normalized()) : pair->direction;
    if (options.mode == DuraOptions::Mode::SLIDING)
      rows.add_sliding_plane(s, x, pair->closest, outward, ConstraintSet::DURA, v);
    else
      rows.add_unilateral_plane(s, x, pair->closest, -outward, ConstraintSet::DURA, v);
  }
  return rows.size() - before;
}

void add_landmark_rows(ConstraintRows& rows, const MappedVertices& mapped, ConstRef<MatrixX3d> x,
                       ConstRef<MatrixX3d> targets) {
  BS_VERIFY(targets.rows() == static_cast<Eigen::Index>(mapped.map->tet().size()),
            "landmarks: " << targets.rows() << " targets for " << mapped.map->tet().size()
                          << " model points");
  for (index_t i = 0; i < targets.rows(); ++i)
    rows.add_bilateral_point(mapped.stencil(i), x, targets.row(i).transpose(),
                             ConstraintSet::LANDMARK, i);
}

}  // namespace brainshift::constraints
