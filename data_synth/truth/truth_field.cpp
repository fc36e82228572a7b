#include "data_synth/truth/truth_field.hpp"

#include "core/error.hpp"
#include "data_synth/images/tet_raster.hpp"

#include <vector>

namespace brainshift::data_synth {

TruthField::TruthField(const core::TetMesh& rest, MatrixX3d displacement, double max_outside)
    : m_rest(rest.nodes()),
      m_tets(rest.tets()),
      m_u(std::move(displacement)),
      m_max_outside(max_outside),
      m_locator(rest.nodes(), rest.tets()) {
  BS_VERIFY(m_u.rows() == m_rest.rows(), "truth displacement has "
                                             << m_u.rows() << " rows, the mesh " << m_rest.rows()
                                             << " nodes");
  BS_VERIFY(m_u.allFinite(), "truth displacement has non-finite values");
  BS_VERIFY(max_outside >= 0.0, "max_outside must be >= 0 mm, got " << max_outside);
}

std::optional<Vector3d> TruthField::try_displacement_at(const Vector3d& X) const {
  const auto loc = m_locator.locate(X, m_max_outside);
  if (!loc) return std::nullopt;
  Vector3d u = Vector3d::Zero();
  for (int a = 0; a < 4; ++a) u += loc->barycentric[a] * m_u.row(m_tets(loc->tet, a)).transpose();
  return u;
}

Vector3d TruthField::displacement_at(const Vector3d& X) const {
  const auto u = try_displacement_at(X);
  BS_VERIFY(u.has_value(), "point (" << X.transpose() << ") mm is farther than " << m_max_outside
                                     << " mm from the truth mesh");
  return *u;
}

imaging::VolumeF TruthField::displacement_image(const imaging::ImageGeometry& grid) const {
  imaging::VolumeF image(grid, 3, 0.0F);
  std::vector<std::uint8_t> inside(std::size_t(grid.voxel_count()), 0);
  rasterize_tets(m_rest, m_tets, grid, [&](std::int64_t v, index_t t, const Vector4d& w) {
    Vector3d u = Vector3d::Zero();
    for (int a = 0; a < 4; ++a) u += w[a] * m_u.row(m_tets(t, a)).transpose();
    for (int c = 0; c < 3; ++c) image.data[std::size_t(v * 3 + c)] = float(u[c]);
    inside[std::size_t(v)] = 1;
  });
  // Closest-point values in a shell around the mesh: only voxels of the mesh's bounding box
  // grown by max_outside can be near it.
  const Vector3d lo = m_rest.colwise().minCoeff().transpose().array() - m_max_outside;
  const Vector3d hi = m_rest.colwise().maxCoeff().transpose().array() + m_max_outside;
  for (int k = 0; k < grid.size[2]; ++k)
    for (int j = 0; j < grid.size[1]; ++j)
      for (int i = 0; i < grid.size[0]; ++i) {
        const std::int64_t v = grid.linear_index(i, j, k);
        if (inside[std::size_t(v)]) continue;
        const Vector3d p = grid.index_to_world(Vector3d(i, j, k));
        if ((p.array() < lo.array()).any() || (p.array() > hi.array()).any()) continue;
        if (const auto u = try_displacement_at(p))
          for (int c = 0; c < 3; ++c) image.data[std::size_t(v * 3 + c)] = float((*u)[c]);
      }
  return image;
}

}  // namespace brainshift::data_synth
