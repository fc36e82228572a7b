#include "data_synth/geometry/structured_mesh.hpp"

#include "core/error.hpp"

#include <array>
#include <cmath>
#include <functional>

namespace brainshift::data_synth {
namespace {

/// Grid of (n+1)^3 nodes on [-1,1]^3 (or [0,1]^3), mapped by `map`, split into Kuhn tetrahedra.
core::TetMesh make_mapped_grid(const Eigen::Vector3i& cells,
                               const std::function<Vector3d(const Vector3d&)>& map) {
  BS_VERIFY((cells.array() >= 1).all(),
            "mesh needs at least one cell per axis, got " << cells.transpose());
  const int nx = cells.x() + 1, ny = cells.y() + 1, nz = cells.z() + 1;
  MatrixX3d nodes(static_cast<Eigen::Index>(nx) * ny * nz, 3);
  auto id = [&](int i, int j, int k) { return i + nx * (j + ny * k); };
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        const Vector3d unit(double(i) / cells.x(), double(j) / cells.y(), double(k) / cells.z());
        nodes.row(id(i, j, k)) = map(unit).transpose();
      }
  // Kuhn subdivision: 6 paths from corner 000 to 111, one per axis permutation.
  static constexpr std::array<std::array<int, 3>, 6> perms = {
      {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}}};
  MatrixX4i tets(6 * static_cast<Eigen::Index>(cells.prod()), 4);
  Eigen::Index t = 0;
  for (int k = 0; k < cells.z(); ++k)
    for (int j = 0; j < cells.y(); ++j)
      for (int i = 0; i < cells.x(); ++i)
        for (const auto& p : perms) {
          std::array<int, 3> c = {i, j, k};
          std::array<index_t, 4> v{};
          v[0] = id(c[0], c[1], c[2]);
          for (int s = 0; s < 3; ++s) {
            ++c[p[s]];
            v[s + 1] = id(c[0], c[1], c[2]);
          }
          const double vol = core::signed_tet_volume(nodes.row(v[0]), nodes.row(v[1]),
                                                     nodes.row(v[2]), nodes.row(v[3]));
          if (vol < 0) std::swap(v[2], v[3]);
          tets.row(t++) << v[0], v[1], v[2], v[3];
        }
  return core::TetMesh(std::move(nodes), std::move(tets));
}

}  // namespace

core::TetMesh make_box_mesh(const Vector3d& size, const Eigen::Vector3i& cells,
                            const Vector3d& origin) {
  BS_VERIFY((size.array() > 0).all(), "box size must be positive, got " << size.transpose());
  return make_mapped_grid(
      cells, [&](const Vector3d& u) -> Vector3d { return origin + u.cwiseProduct(size); });
}

core::TetMesh make_cylinder_mesh(double radius, double length, int radial_cells, int axial_cells,
                                 const Vector3d& centre) {
  BS_VERIFY(radius > 0 && length > 0, "cylinder radius and length must be positive");
  return make_mapped_grid({radial_cells, radial_cells, axial_cells},
                          [&](const Vector3d& u) -> Vector3d {
                            const double x = 2 * u.x() - 1, y = 2 * u.y() - 1;
                            // Square-to-disc map (Fong's elliptical grid mapping).
                            const double dx = x * std::sqrt(1 - y * y / 2);
                            const double dy = y * std::sqrt(1 - x * x / 2);
                            return centre + Vector3d(radius * dx, radius * dy, length * u.z());
                          });
}

core::TetMesh make_ellipsoid_mesh(const Vector3d& semi_axes, int cells, const Vector3d& centre) {
  BS_VERIFY((semi_axes.array() > 0).all(), "ellipsoid semi-axes must be positive");
  return make_mapped_grid({cells, cells, cells}, [&](const Vector3d& u) -> Vector3d {
    const Vector3d c = 2 * u.array() - 1;
    const double x2 = c.x() * c.x(), y2 = c.y() * c.y(), z2 = c.z() * c.z();
    // Cube-to-ball map: smooth, bijective, keeps the Kuhn tetrahedra positively oriented.
    const Vector3d b(c.x() * std::sqrt(1 - y2 / 2 - z2 / 2 + y2 * z2 / 3),
                     c.y() * std::sqrt(1 - z2 / 2 - x2 / 2 + z2 * x2 / 3),
                     c.z() * std::sqrt(1 - x2 / 2 - y2 / 2 + x2 * y2 / 3));
    return centre + b.cwiseProduct(semi_axes);
  });
}

}  // namespace brainshift::data_synth
