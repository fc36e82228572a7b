#include "imaging/meshing/wrap_surface.hpp"

#include "core/error.hpp"
#include "core/logger.hpp"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/alpha_wrap_3.h>

#include <array>
#include <cmath>
#include <vector>

namespace brainshift::imaging {

namespace {
using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Mesh = CGAL::Surface_mesh<Kernel::Point_3>;
}  // namespace

core::SurfaceMesh wrap_surface(const core::SurfaceMesh& soup, double alpha, double offset) {
  BS_VERIFY(std::isfinite(alpha) && alpha > 0.0,
            "surface wrap: alpha must be > 0 mm, got " << alpha);
  BS_VERIFY(std::isfinite(offset) && offset > 0.0,
            "surface wrap: offset must be > 0 mm, got " << offset);
  const auto& V = soup.vertices;
  const auto& F = soup.triangles;
  BS_VERIFY(F.rows() > 0, "surface wrap: the surface has no triangle");
  std::vector<Kernel::Point_3> points;
  points.reserve(std::size_t(V.rows()));
  for (index_t v = 0; v < V.rows(); ++v) {
    BS_VERIFY(V.row(v).allFinite(), "surface wrap: vertex " << v << " is not finite");
    points.emplace_back(V(v, 0), V(v, 1), V(v, 2));
  }
  std::vector<std::array<std::size_t, 3>> faces;
  faces.reserve(std::size_t(F.rows()));
  for (index_t f = 0; f < F.rows(); ++f) {
    for (int c = 0; c < 3; ++c) {
      BS_VERIFY(F(f, c) >= 0 && F(f, c) < V.rows(),
                "surface wrap: triangle " << f << " refers to vertex " << F(f, c)
                                          << ", but there are " << V.rows() << " vertices");
    }
    faces.push_back({std::size_t(F(f, 0)), std::size_t(F(f, 1)), std::size_t(F(f, 2))});
  }
  Mesh wrap;
  CGAL::alpha_wrap_3(points, faces, alpha, offset, wrap);
  BS_VERIFY(wrap.number_of_faces() > 0, "internal error: the surface wrap is empty");

  core::SurfaceMesh out;
  out.vertices.resize(index_t(wrap.number_of_vertices()), 3);
  std::vector<index_t> id(wrap.num_vertices(), -1);
  index_t n = 0;
  for (auto v : wrap.vertices()) {
    const auto& p = wrap.point(v);
    id[v.idx()] = n;
    out.vertices.row(n++) << p.x(), p.y(), p.z();
  }
  out.triangles.resize(index_t(wrap.number_of_faces()), 3);
  index_t t = 0;
  double volume = 0.0;
  for (auto f : wrap.faces()) {
    int c = 0;
    for (auto v : CGAL::vertices_around_face(wrap.halfedge(f), wrap))
      out.triangles(t, c++) = id[v.idx()];
    const Vector3d a = out.vertices.row(out.triangles(t, 0)),
                   b = out.vertices.row(out.triangles(t, 1)),
                   d = out.vertices.row(out.triangles(t, 2));
    volume += a.dot(b.cross(d)) / 6.0;
    ++t;
  }
  if (volume < 0.0) out.triangles.col(1).swap(out.triangles.col(2));  // outward normals
  logger().info("wrapped surface (alpha {} mm, offset {} mm): {} → {} vertices", alpha, offset,
                V.rows(), out.vertices.rows());
  return out;
}

}  // namespace brainshift::imaging
