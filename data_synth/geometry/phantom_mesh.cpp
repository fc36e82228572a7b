#include "data_synth/geometry/phantom_mesh.hpp"

#include "core/error.hpp"
#include "core/logger.hpp"

#include <array>
#include <cmath>
#include <functional>
#include <optional>
#include <sstream>

namespace brainshift::data_synth {
namespace {

/// Five-tetrahedron split of a cube; corners numbered dx + 2dy + 4dz. Even cubes use the
/// even-corner central tetrahedron, odd cubes the odd-corner one, so every face diagonal joins
/// two nodes of even global parity and neighbouring cubes conform.
constexpr std::array<std::array<int, 4>, 5> even_split = {
    {{0, 3, 5, 6}, {1, 0, 3, 5}, {2, 0, 3, 6}, {4, 0, 5, 6}, {7, 3, 5, 6}}};
constexpr std::array<std::array<int, 4>, 5> odd_split = {
    {{1, 2, 4, 7}, {0, 1, 2, 4}, {3, 1, 2, 7}, {5, 1, 4, 7}, {6, 2, 4, 7}}};

/// Cube faces as (axis, side): the four corners of face (axis a, side s) have bit a equal to s.
struct Grid {
  Vector3d origin;  ///< node (0,0,0), mm
  double h = 0.0;
  Eigen::Vector3i cells;
  [[nodiscard]] std::int64_t node_id(int i, int j, int k) const {
    return (std::int64_t(k) * (cells.y() + 1) + j) * (cells.x() + 1) + i;
  }
  [[nodiscard]] std::int64_t cell_id(int i, int j, int k) const {
    return (std::int64_t(k) * cells.y() + j) * cells.x() + i;
  }
  [[nodiscard]] Vector3d node(int i, int j, int k) const { return origin + h * Vector3d(i, j, k); }
};

}  // namespace

std::string PhantomMeshOptions::validate() const {
  std::ostringstream s;
  if (!(cell_size > 0.0))
    s << "cell_size must be positive, got " << cell_size << " mm";
  else if (!(min_snapped_volume_fraction > 0.0 && min_snapped_volume_fraction < 1.0))
    s << "min_snapped_volume_fraction must be in (0, 1), got " << min_snapped_volume_fraction;
  else if (!(brain_youngs_modulus > 0.0 && tumour_youngs_modulus > 0.0 &&
             ventricle_youngs_modulus > 0.0))
    s << "Young's moduli must be positive (brain " << brain_youngs_modulus << ", tumour "
      << tumour_youngs_modulus << ", ventricles " << ventricle_youngs_modulus << " kPa)";
  else if (!(poisson_ratio > -1.0 && poisson_ratio < 0.5))
    s << "poisson_ratio must be in (-1, 0.5), got " << poisson_ratio;
  return s.str();
}

CubeTets make_cube_tets(const Vector3d& origin, double h, const Eigen::Vector3i& cells,
                        const std::function<bool(const Vector3d&)>& inside) {
  Grid grid;
  grid.h = h;
  grid.cells = cells;
  grid.origin = origin;
  std::vector<char> kept(std::size_t(grid.cells.prod()), 0);
  for (int k = 0; k < grid.cells.z(); ++k)
    for (int j = 0; j < grid.cells.y(); ++j)
      for (int i = 0; i < grid.cells.x(); ++i)
        kept[std::size_t(grid.cell_id(i, j, k))] =
            inside(grid.node(i, j, k) + Vector3d::Constant(0.5 * h)) ? 1 : 0;
  auto is_kept = [&](int i, int j, int k) {
    return i >= 0 && j >= 0 && k >= 0 && i < grid.cells.x() && j < grid.cells.y() &&
           k < grid.cells.z() && kept[std::size_t(grid.cell_id(i, j, k))];
  };

  // Nodes of kept cubes, numbered in grid order; boundary flags from exposed cube faces.
  const std::size_t grid_nodes = std::size_t(grid.node_id(0, 0, grid.cells.z() + 1));
  std::vector<index_t> node_of(grid_nodes, -1);
  std::vector<char> boundary(grid_nodes, 0);
  CubeTets out;
  for (int k = 0; k < grid.cells.z(); ++k)
    for (int j = 0; j < grid.cells.y(); ++j)
      for (int i = 0; i < grid.cells.x(); ++i) {
        if (!is_kept(i, j, k)) continue;
        for (int c = 0; c < 8; ++c) {
          const Eigen::Vector3i n(i + (c & 1), j + ((c >> 1) & 1), k + ((c >> 2) & 1));
          const auto id = std::size_t(grid.node_id(n.x(), n.y(), n.z()));
          if (node_of[id] < 0) {
            node_of[id] = index_t(out.ijk.size());
            out.ijk.push_back(n);
          }
        }
        for (int axis = 0; axis < 3; ++axis)
          for (int side = 0; side < 2; ++side) {
            Eigen::Vector3i nb(i, j, k);
            nb[axis] += side == 0 ? -1 : 1;
            if (is_kept(nb.x(), nb.y(), nb.z())) continue;
            for (int c = 0; c < 8; ++c) {
              if (((c >> axis) & 1) != side) continue;
              boundary[std::size_t(
                  grid.node_id(i + (c & 1), j + ((c >> 1) & 1), k + ((c >> 2) & 1)))] = 1;
            }
          }
      }
  out.nodes.resize(Eigen::Index(out.ijk.size()), 3);
  out.boundary.resize(out.ijk.size());
  for (std::size_t n = 0; n < out.ijk.size(); ++n) {
    const Eigen::Vector3i& ijk = out.ijk[n];
    out.nodes.row(Eigen::Index(n)) = grid.node(ijk.x(), ijk.y(), ijk.z()).transpose();
    out.boundary[n] = boundary[std::size_t(grid.node_id(ijk.x(), ijk.y(), ijk.z()))];
  }
  const MatrixX3d& rest = out.nodes;
  for (int k = 0; k < grid.cells.z(); ++k)
    for (int j = 0; j < grid.cells.y(); ++j)
      for (int i = 0; i < grid.cells.x(); ++i) {
        if (!is_kept(i, j, k)) continue;
        std::array<index_t, 8> corner{};
        for (int c = 0; c < 8; ++c)
          corner[std::size_t(c)] = node_of[std::size_t(
              grid.node_id(i + (c & 1), j + ((c >> 1) & 1), k + ((c >> 2) & 1)))];
        const auto& split = ((i + j + k) % 2 == 0) ? even_split : odd_split;
        for (const auto& t : split) {
          std::array<index_t, 4> v{corner[std::size_t(t[0])], corner[std::size_t(t[1])],
                                   corner[std::size_t(t[2])], corner[std::size_t(t[3])]};
          if (core::signed_tet_volume(rest.row(v[0]), rest.row(v[1]), rest.row(v[2]),
                                      rest.row(v[3])) < 0.0)
            std::swap(v[2], v[3]);
          out.tets.push_back(v);
        }
      }
  return out;
}

void undo_flattening_snaps(const MatrixX3d& rest, const std::vector<std::array<index_t, 4>>& tets,
                           double min_fraction, MatrixX3d& nodes, std::vector<char>& snapped) {
  // Undo snaps that flatten a tetrahedron, largest move first; repeat until every tetrahedron is
  // acceptable.
  for (bool changed = true; changed;) {
    changed = false;
    for (const auto& v : tets) {
      const double v0 =
          core::signed_tet_volume(rest.row(v[0]), rest.row(v[1]), rest.row(v[2]), rest.row(v[3]));
      const double v1 = core::signed_tet_volume(nodes.row(v[0]), nodes.row(v[1]), nodes.row(v[2]),
                                                nodes.row(v[3]));
      if (v1 >= min_fraction * v0) continue;
      // Undo the largest snap of this tetrahedron; the next pass re-checks it.
      index_t worst = -1;
      double worst_move = 0.0;
      for (const index_t n : v) {
        const double move = (nodes.row(n) - rest.row(n)).norm();
        if (snapped[std::size_t(n)] && move >= worst_move) {
          worst = n;
          worst_move = move;
        }
      }
      if (worst < 0) continue;
      nodes.row(worst) = rest.row(worst);
      snapped[std::size_t(worst)] = 0;
      changed = true;
    }
  }
}

void assign_materials(MatrixX3d nodes, const std::vector<std::array<index_t, 4>>& tets,
                      const std::function<imaging::Label(const Vector3d&)>& label_at,
                      const PhantomMeshOptions& o, PhantomMesh& out) {
  MatrixX4i T(Eigen::Index(tets.size()), 4);
  Eigen::VectorXd E(T.rows()), nu = Eigen::VectorXd::Constant(T.rows(), o.poisson_ratio);
  out.tet_labels.resize(tets.size());
  for (std::size_t t = 0; t < tets.size(); ++t) {
    Vector3d centroid = Vector3d::Zero();
    for (int a = 0; a < 4; ++a) {
      T(Eigen::Index(t), a) = tets[t][std::size_t(a)];
      centroid += 0.25 * nodes.row(tets[t][std::size_t(a)]).transpose();
    }
    imaging::Label label = label_at(centroid);
    if (label == imaging::BACKGROUND) label = imaging::BRAIN;  // stair-step corners outside
    out.tet_labels[t] = label;
    E(Eigen::Index(t)) = label == imaging::TUMOUR       ? o.tumour_youngs_modulus
                         : label == imaging::VENTRICLES ? o.ventricle_youngs_modulus
                                                        : o.brain_youngs_modulus;
  }
  out.mesh = core::TetMesh(std::move(nodes), std::move(T), std::move(E), std::move(nu));
  core::validate(out.mesh, "phantom mesh");
}

PhantomMesh make_phantom_mesh(const PhantomGeometry& g, const PhantomMeshOptions& o) {
  const std::string bad_geometry = g.validate();
  BS_VERIFY(bad_geometry.empty(), "invalid phantom geometry: " << bad_geometry);
  const std::string bad_options = o.validate();
  BS_VERIFY(bad_options.empty(), "invalid phantom mesh options: " << bad_options);
  const double h = o.cell_size;
  const int nx = int(std::ceil(g.semi_axes.x() / h)) + 1;
  const int ny = int(std::ceil(g.semi_axes.y() / h)) + 1;
  const double height = g.centre.z() + g.semi_axes.z() - g.base_level();
  const CubeTets cubes =
      make_cube_tets(Vector3d(g.centre.x() - nx * h, g.centre.y() - ny * h, g.base_level()), h,
                     {2 * nx, 2 * ny, int(std::ceil(height / h)) + 1},
                     [&](const Vector3d& x) { return g.inside_brain(x); });
  BS_VERIFY(!cubes.ijk.empty(), "phantom mesh is empty: cell_size "
                                    << h << " mm is too large for the brain "
                                    << g.semi_axes.transpose());

  const MatrixX3d& rest = cubes.nodes;
  const std::vector<std::array<index_t, 4>>& tets = cubes.tets;
  PhantomMesh out;
  for (std::size_t n = 0; n < cubes.ijk.size(); ++n) {
    if (cubes.ijk[n].z() == 0)
      out.base_nodes.push_back(index_t(n));
    else if (cubes.boundary[n])
      out.surface_nodes.push_back(index_t(n));
  }

  MatrixX3d nodes = rest;
  if (o.snap_to_surface) {
    const Ellipsoid brain = g.brain_ellipsoid();
    std::vector<char> snapped(cubes.ijk.size(), 0);
    // Horizontal projection onto the ellipsoid's cross-section at the node's height (keeps base
    // nodes on the base plane); only for nodes outside the brain.
    auto horizontal = [&](const Vector3d& x) -> std::optional<Vector3d> {
      const Vector3d p = (x - brain.centre).cwiseQuotient(brain.semi_axes);
      const double r2 = p.x() * p.x() + p.y() * p.y(), target = 1.0 - p.z() * p.z();
      if (p.squaredNorm() <= 1.0 || r2 <= 0.0 || target <= 0.0) return std::nullopt;
      const double scale = std::sqrt(target / r2);
      return Vector3d(brain.centre.x() + scale * (x.x() - brain.centre.x()),
                      brain.centre.y() + scale * (x.y() - brain.centre.y()), x.z());
    };
    auto snap = [&](index_t n, const Vector3d& q) {
      nodes.row(n) = q.transpose();
      snapped[std::size_t(n)] = 1;
    };
    for (const index_t n : out.base_nodes)
      if (const auto q = horizontal(rest.row(n).transpose())) snap(n, *q);
    for (const index_t n : out.surface_nodes) {
      const Vector3d x = rest.row(n).transpose(), q = brain.closest_point(x);
      if (q.z() >= g.base_level() + 0.5 * h)
        snap(n, q);
      else if (const auto qh = horizontal(x))
        snap(n, *qh);  // near the base: stay above it
    }
    undo_flattening_snaps(rest, tets, o.min_snapped_volume_fraction, nodes, snapped);
    for (const char s : snapped) out.snapped_nodes += s;
  }

  assign_materials(
      std::move(nodes), tets, [&](const Vector3d& x) { return g.label_at(x); }, o, out);
  logger().debug("phantom mesh: h {} mm, {} nodes, {} tets, {} snapped of {} surface nodes", h,
                 out.mesh.num_nodes(), out.mesh.num_tets(), out.snapped_nodes,
                 out.surface_nodes.size());
  return out;
}

}  // namespace brainshift::data_synth
