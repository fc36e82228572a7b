#include "imaging/meshing/collision_surface.hpp"

#include "core/error.hpp"
#include "core/logger.hpp"
#include "core/mapping/tet_locator.hpp"
#include "imaging/meshing/decimate_surface.hpp"
#include "imaging/meshing/wrap_surface.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <sstream>
#include <vector>

namespace brainshift::imaging {

namespace {

index_t find_root(std::vector<index_t>& parent, index_t v) {
  while (parent[std::size_t(v)] != v) {
    parent[std::size_t(v)] = parent[std::size_t(parent[std::size_t(v)])];
    v = parent[std::size_t(v)];
  }
  return v;
}

}  // namespace

std::string CollisionSurfaceOptions::validate() const {
  std::ostringstream s;
  const auto positive = [](double x) { return std::isfinite(x) && x > 0.0; };
  if (target_vertices < 4)
    s << "target_vertices must be ≥ 4, got " << target_vertices;
  else if (!positive(wrap_alpha_mm))
    s << "wrap_alpha_mm must be > 0 mm, got " << wrap_alpha_mm;
  else if (!positive(wrap_offset_mm))
    s << "wrap_offset_mm must be > 0 mm, got " << wrap_offset_mm;
  else if (!(max_outside_mm >= 0.0 && max_outside_mm < 2.0))
    s << "max_outside_mm must be in [0, 2) mm, got " << max_outside_mm;
  return s.str();
}

index_t count_non_manifold_vertices(const core::SurfaceMesh& surface) {
  const auto& F = surface.triangles;
  const index_t nv = surface.vertices.rows();
  // Triangles around each vertex (CSR).
  std::vector<index_t> start(std::size_t(nv) + 1, 0), around(std::size_t(3 * F.rows()));
  for (index_t f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) ++start[std::size_t(F(f, c)) + 1];
  std::partial_sum(start.begin(), start.end(), start.begin());
  std::vector<index_t> fill(start.begin(), start.end() - 1);
  for (index_t f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) around[std::size_t(fill[std::size_t(F(f, c))]++)] = f;
  // The link of a manifold vertex: its triangles' opposite edges form one cycle, so every link
  // vertex has degree 2 and the link is connected.
  index_t bad = 0;
  std::vector<index_t> link, parent, degree;
  for (index_t v = 0; v < nv; ++v) {
    const index_t b = start[std::size_t(v)], e = start[std::size_t(v) + 1];
    if (b == e) continue;
    link.clear();
    for (index_t k = b; k < e; ++k)
      for (int c = 0; c < 3; ++c)
        if (F(around[std::size_t(k)], c) != v) link.push_back(F(around[std::size_t(k)], c));
    std::vector<index_t> ids(link);
    std::sort(ids.begin(), ids.end());
    ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
    const auto id = [&](index_t w) {
      return index_t(std::lower_bound(ids.begin(), ids.end(), w) - ids.begin());
    };
    parent.resize(ids.size());
    std::iota(parent.begin(), parent.end(), 0);
    degree.assign(ids.size(), 0);
    for (std::size_t k = 0; k + 1 < link.size(); k += 2) {
      const index_t p = id(link[k]), q = id(link[k + 1]);
      ++degree[std::size_t(p)];
      ++degree[std::size_t(q)];
      parent[std::size_t(find_root(parent, p))] = find_root(parent, q);
    }
    bool ok = std::all_of(degree.begin(), degree.end(), [](index_t d) { return d == 2; });
    for (std::size_t k = 0; ok && k < ids.size(); ++k)
      ok = find_root(parent, index_t(k)) == find_root(parent, 0);
    bad += !ok;
  }
  return bad;
}

CollisionSurface make_collision_surface(const core::TetMesh& mesh, const MeshSurface& outer,
                                        const CollisionSurfaceOptions& options) {
  const std::string bad = options.validate();
  BS_VERIFY(bad.empty(), "collision surface options: " << bad);
  BS_VERIFY(outer.surface.triangles.rows() > 0,
            "collision surface: the mesh boundary has no triangle");
  CollisionSurface out;
  out.boundary_vertices = outer.surface.vertices.rows();
  out.non_manifold_edges = count_non_manifold_edges(outer.surface);
  out.non_manifold_vertices = count_non_manifold_vertices(outer.surface);
  out.wrapped = out.non_manifold_edges > 0 || out.non_manifold_vertices > 0;
  if (out.wrapped) {
    logger().info("the mesh boundary is not a manifold ({} edges, {} vertices): wrapping it",
                  out.non_manifold_edges, out.non_manifold_vertices);
    out.surface =
        decimate_surface(wrap_surface(outer.surface, options.wrap_alpha_mm, options.wrap_offset_mm),
                         options.target_vertices);
  } else {
    out.surface = decimate_surface(outer.surface, options.target_vertices);
  }
  // Decimation places vertices to keep the volume, the wrap lies outside: move the vertices that
  // ended too far out onto the mesh.
  const core::TetLocator locator(mesh.nodes(), mesh.tets());
  auto& V = out.surface.vertices;
  for (index_t v = 0; v < V.rows(); ++v) {
    const Vector3d p = V.row(v).transpose();
    if (const auto near = locator.locate(p, options.max_outside_mm)) {
      out.max_outside_mm = std::max(out.max_outside_mm, near->distance);
      continue;
    }
    const auto loc = locator.locate(p, std::numeric_limits<double>::infinity());
    BS_VERIFY(loc.has_value(),
              "internal error: collision surface vertex " << v << " is not near the mesh");
    Vector3d q = Vector3d::Zero();
    for (int k = 0; k < 4; ++k)
      q += loc->barycentric(k) * mesh.nodes().row(mesh.tets()(loc->tet, k)).transpose();
    out.max_outside_mm = std::max(out.max_outside_mm, loc->distance);
    V.row(v) = q.transpose();
    ++out.moved_vertices;
  }
  return out;
}

}  // namespace brainshift::imaging
