#include "imaging/meshing/model_defaults.hpp"

#include "core/error.hpp"
#include "imaging/io/volume.hpp"

#include <cmath>
#include <sstream>

namespace brainshift::imaging {

FixedRegion default_fixed_region(const MeshSurface& outer, const Vector3d& down, double fraction,
                                 double min_height_mm) {
  BS_VERIFY(down.allFinite() && down.norm() > 0.0,
            "fixed region: the down direction must be a non-zero vector, got " << down.transpose());
  BS_VERIFY(fraction >= 0.0 && fraction <= 1.0,
            "fixed region: fraction must be in [0, 1], got " << fraction);
  BS_VERIFY(std::isfinite(min_height_mm) && min_height_mm >= 0.0,
            "fixed region: minimum height must be ≥ 0 mm, got " << min_height_mm);
  FixedRegion r;
  r.down = down.normalized();
  if (outer.surface.vertices.rows() > 0) {
    const Eigen::VectorXd depth = outer.surface.vertices * r.down;
    r.extent_mm = depth.maxCoeff() - depth.minCoeff();
  }
  r.height_mm = std::max(min_height_mm, fraction * r.extent_mm);
  r.nodes = fixed_region_nodes(outer, r.down, r.height_mm);
  std::ostringstream s;
  s << "boundary nodes within " << r.height_mm << " mm of the lowest point along (" << r.down.x()
    << ", " << r.down.y() << ", " << r.down.z() << ") (max(" << min_height_mm << " mm, "
    << fraction * 100.0 << " % of the " << r.extent_mm
    << " mm extent)): the part of the brain on the skull base (on an adult brain the "
       "brain stem, the cerebellum and the inferior temporal and frontal lobes)";
  r.rule = s.str();
  return r;
}

Craniotomy default_craniotomy(const core::SurfaceMesh& surface, const core::TetMesh& mesh,
                              const std::vector<std::uint8_t>& tet_label, double radius_mm) {
  const auto& V = surface.vertices;
  BS_VERIFY(V.rows() > 0, "craniotomy: the collision surface has no vertex");
  BS_VERIFY(tet_label.empty() || index_t(tet_label.size()) == mesh.num_tets(),
            "craniotomy: " << tet_label.size() << " tetrahedron labels for " << mesh.num_tets()
                           << " tetrahedra");
  BS_VERIFY(std::isfinite(radius_mm) && radius_mm > 0.0,
            "craniotomy: radius must be > 0 mm, got " << radius_mm);
  Craniotomy c;
  c.radius_mm = radius_mm;
  // Volume-weighted centroid of the tumour tetrahedra.
  Vector3d sum = Vector3d::Zero();
  double volume = 0.0;
  for (index_t t = 0; t < index_t(tet_label.size()); ++t) {
    if (tet_label[std::size_t(t)] != TUMOUR) continue;
    const auto n = [&](int k) { return Vector3d(mesh.nodes().row(mesh.tets()(t, k)).transpose()); };
    const double v = std::abs(core::signed_tet_volume(n(0), n(1), n(2), n(3)));
    sum += v * (n(0) + n(1) + n(2) + n(3)) / 4.0;
    volume += v;
  }
  std::ostringstream s;
  Eigen::Index best = 0;
  if (volume > 0.0) {
    const Vector3d tumour = sum / volume;
    (V.rowwise() - tumour.transpose()).rowwise().squaredNorm().minCoeff(&best);
    s << "over the tumour: the surface point nearest its centroid (" << tumour.x() << ", "
      << tumour.y() << ", " << tumour.z() << ") mm, " << (V.row(best).transpose() - tumour).norm()
      << " mm away";
  } else {
    V.col(2).maxCoeff(&best);
    s << "no tumour: the top of the brain (the highest surface point)";
  }
  c.centre = V.row(best).transpose();
  c.rule = s.str();
  return c;
}

}  // namespace brainshift::imaging
