#pragma once
/// @file
/// @brief Vessel skeleton graphs and triangle surfaces: the geometry shared by imaging (extraction,
/// meshing, I/O), the registration (the features intra-operative points are paired with) and the
/// phantoms. Positions in mm, world (RAS) frame.

#include "core/config.hpp"

#include <array>
#include <vector>

namespace brainshift::core {

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

}  // namespace brainshift::core
