#pragma once
/// @file
/// @brief Point location in a tetrahedral mesh: which tetrahedron contains a point, or which is
/// nearest when the point lies just outside. The project's grid index over the tetrahedra's
/// bounding boxes (core/spatial/grid_index.hpp) gives O(1) candidates per query.

#include "core/config.hpp"
#include "core/spatial/grid_index.hpp"

#include <optional>
#include <vector>

namespace brainshift::core {

/// A located point: its tetrahedron, barycentric coordinates and distance to that tetrahedron.
struct TetLocation {
  index_t tet = -1;
  Vector4d barycentric = Vector4d::Zero();  ///< sums to 1; all ≥ 0 when inside
  double distance = 0.0;                    ///< 0 inside, else distance to the tetrahedron, mm
};

class TetLocator {
 public:
  /// @param[in] nodes #N×3 (mm), @param[in] tets #T×4. Both copied.
  TetLocator(ConstRef<MatrixX3d> nodes, ConstRef<MatrixX4i> tets);

  /// The tetrahedron containing p, else the nearest one within `max_distance` (mm), with the
  /// barycentric coordinates of the closest point of that tetrahedron (clamped, not
  /// extrapolated); std::nullopt when nothing lies within `max_distance`.
  [[nodiscard]] std::optional<TetLocation> locate(const Vector3d& p, double max_distance) const;

 private:
  MatrixX3d m_nodes;
  MatrixX4i m_tets;
  GridIndex m_grid;  // over the tetrahedra's bounding boxes
};

/// Barycentric coordinates of p w.r.t. the tetrahedron with rows X (may be negative outside).
Vector4d barycentric_coordinates(const Eigen::Matrix<double, 4, 3>& X, const Vector3d& p);

}  // namespace brainshift::core
