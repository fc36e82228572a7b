#include "imaging/meshing/decimate_surface.hpp"

#include "core/error.hpp"
#include "core/logger.hpp"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/Bounded_normal_change_placement.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/Count_stop_predicate.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/LindstromTurk_cost.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/LindstromTurk_placement.h>
#include <CGAL/Surface_mesh_simplification/edge_collapse.h>
#include <CGAL/boost/graph/helpers.h>

#include <map>
#include <utility>
#include <vector>

namespace brainshift::imaging {

namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Mesh = CGAL::Surface_mesh<Kernel::Point_3>;
namespace SMS = CGAL::Surface_mesh_simplification;

Mesh to_cgal(const core::SurfaceMesh& surface) {
  const auto& V = surface.vertices;
  const auto& F = surface.triangles;
  Mesh sm;
  std::vector<Mesh::Vertex_index> vertex(std::size_t(V.rows()));
  for (index_t v = 0; v < V.rows(); ++v) {
    BS_VERIFY(V.row(v).allFinite(), "surface vertex " << v << " is not finite");
    vertex[std::size_t(v)] = sm.add_vertex(Kernel::Point_3(V(v, 0), V(v, 1), V(v, 2)));
  }
  for (index_t f = 0; f < F.rows(); ++f) {
    for (int c = 0; c < 3; ++c) {
      BS_VERIFY(F(f, c) >= 0 && F(f, c) < V.rows(),
                "surface triangle " << f << " refers to vertex " << F(f, c) << ", but there are "
                                    << V.rows() << " vertices");
    }
    const auto face = sm.add_face(vertex[std::size_t(F(f, 0))], vertex[std::size_t(F(f, 1))],
                                  vertex[std::size_t(F(f, 2))]);
    BS_VERIFY(face != Mesh::null_face(),
              "surface triangle " << f << " (" << F(f, 0) << ", " << F(f, 1) << ", " << F(f, 2)
                                  << ") makes the surface non-manifold or inconsistently "
                                     "oriented; decimation needs a closed manifold surface");
  }
  BS_VERIFY(
      CGAL::is_closed(sm),
      "surface of " << V.rows() << " vertices and " << F.rows()
                    << " triangles has open edges; decimation needs a closed manifold surface");
  return sm;
}

}  // namespace

index_t count_non_manifold_edges(const core::SurfaceMesh& surface) {
  std::map<std::pair<index_t, index_t>, int> faces_of_edge;
  for (index_t f = 0; f < surface.triangles.rows(); ++f)
    for (int c = 0; c < 3; ++c) {
      const index_t a = surface.triangles(f, c), b = surface.triangles(f, (c + 1) % 3);
      ++faces_of_edge[{std::min(a, b), std::max(a, b)}];
    }
  index_t n = 0;
  for (const auto& [edge, count] : faces_of_edge) n += count > 2;
  return n;
}

core::SurfaceMesh decimate_surface(const core::SurfaceMesh& surface, index_t target_vertices) {
  BS_VERIFY(target_vertices >= 4,
            "decimation target must be ≥ 4 vertices, got " << target_vertices);
  Mesh sm = to_cgal(surface);
  const auto euler = std::int64_t(sm.number_of_vertices()) - std::int64_t(sm.number_of_edges()) +
                     std::int64_t(sm.number_of_faces());
  if (std::int64_t(sm.number_of_vertices()) > target_vertices) {
    // Closed triangle mesh: 3F = 2E and V − E + F = χ, so V vertices ⇔ E = 3 (V − χ) edges.
    const auto target_edges = std::max<std::int64_t>(6, 3 * (target_vertices - euler));
    SMS::Count_stop_predicate<Mesh> stop(std::size_t(target_edges) + 1);
    SMS::LindstromTurk_placement<Mesh> lt_placement;
    SMS::Bounded_normal_change_placement<SMS::LindstromTurk_placement<Mesh>> placement(
        lt_placement);
    SMS::edge_collapse(
        sm, stop,
        CGAL::parameters::get_cost(SMS::LindstromTurk_cost<Mesh>()).get_placement(placement));
    sm.collect_garbage();
  }
  BS_VERIFY(CGAL::is_closed(sm), "internal error: decimated surface is not closed");

  core::SurfaceMesh out;
  out.vertices.resize(index_t(sm.number_of_vertices()), 3);
  for (auto v : sm.vertices()) {
    const auto& p = sm.point(v);
    out.vertices.row(index_t(v.idx())) << p.x(), p.y(), p.z();
  }
  out.triangles.resize(index_t(sm.number_of_faces()), 3);
  for (auto f : sm.faces()) {
    int c = 0;
    for (auto v : CGAL::vertices_around_face(sm.halfedge(f), sm)) {
      out.triangles(index_t(f.idx()), c++) = index_t(v.idx());
    }
  }
  logger().info("decimated surface: {} → {} vertices ({} triangles)", surface.vertices.rows(),
                out.vertices.rows(), out.triangles.rows());
  return out;
}

}  // namespace brainshift::imaging
