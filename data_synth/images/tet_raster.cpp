#include "data_synth/images/tet_raster.hpp"

#include "core/mapping/tet_locator.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

namespace brainshift::data_synth {

std::int64_t rasterize_tets(ConstRef<MatrixX3d> nodes, ConstRef<MatrixX4i> tets,
                            const imaging::ImageGeometry& grid, const VoxelInTetVisitor& visit) {
  constexpr double inside_tolerance = 1e-9;  // barycentric: counts voxels on faces as inside
  std::vector<std::uint8_t> done(std::size_t(grid.voxel_count()), 0);
  std::int64_t visited = 0;
  for (index_t t = 0; t < tets.rows(); ++t) {
    Eigen::Matrix<double, 4, 3> X;
    Vector3d lo = Vector3d::Constant(1e300), hi = Vector3d::Constant(-1e300);
    for (int a = 0; a < 4; ++a) {
      X.row(a) = nodes.row(tets(t, a));
      const Vector3d ijk = grid.world_to_index(X.row(a).transpose());
      lo = lo.cwiseMin(ijk);
      hi = hi.cwiseMax(ijk);
    }
    Eigen::Vector3i a, b;
    for (int d = 0; d < 3; ++d) {
      a[d] = std::max(0, int(std::ceil(lo[d] - 1e-9)));
      b[d] = std::min(grid.size[d] - 1, int(std::floor(hi[d] + 1e-9)));
    }
    for (int k = a[2]; k <= b[2]; ++k)
      for (int j = a[1]; j <= b[1]; ++j)
        for (int i = a[0]; i <= b[0]; ++i) {
          const std::int64_t v = grid.linear_index(i, j, k);
          if (done[std::size_t(v)]) continue;
          const Vector4d w =
              core::barycentric_coordinates(X, grid.index_to_world(Vector3d(i, j, k)));
          if (w.minCoeff() < -inside_tolerance) continue;
          done[std::size_t(v)] = 1;
          ++visited;
          visit(v, t, w);
        }
  }
  return visited;
}

}  // namespace brainshift::data_synth
