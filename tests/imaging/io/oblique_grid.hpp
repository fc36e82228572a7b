#pragma once
// The I/O tests' grid: oblique, anisotropic, off-centre (so that no axis or sign mix-up can pass).
#include "imaging/io/volume.hpp"

#include <Eigen/Geometry>

namespace brainshift::imaging::test_grids {

inline ImageGeometry oblique_geometry(bool left_handed = false) {
  ImageGeometry g;
  g.size = {7, 5, 4};
  g.spacing = {0.8, 1.1, 2.5};
  g.origin = {-31.5, 12.25, 70.0};
  g.direction = (Eigen::AngleAxisd(0.3, Vector3d::UnitZ()) *
                 Eigen::AngleAxisd(-0.2, Vector3d(1, 1, 0).normalized()))
                    .toRotationMatrix();
  if (left_handed) g.direction.col(2) *= -1.0;
  return g;
}

}  // namespace brainshift::imaging::test_grids
