#pragma once
/// @file
/// @brief Vessel skeleton graphs and triangle surfaces: the pre-operative features that
/// intra-operative points are paired with. Positions in mm, world (RAS) frame.

#include "core/config.hpp"

#include <array>
#include <vector>

namespace brainshift::constraints {

/// A vessel skeleton: points joined by segments, with a radius per point (mm).
struct Skeleton {
  MatrixX3d points;                              ///< #P×3, mm
  std::vector<std::array<index_t, 2>> segments;  ///< point pairs
  Eigen::VectorXd radius;                        ///< #P, mm (may be empty)
};

/// A triangle surface (collision surface, dura, footprint).
struct SurfaceMesh {
  MatrixX3d vertices;                                                    ///< #V×3, mm
  Eigen::Matrix<index_t, Eigen::Dynamic, 3, Eigen::RowMajor> triangles;  ///< #F×3
};

}  // namespace brainshift::constraints
