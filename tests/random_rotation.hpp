#pragma once
/// @file
/// @brief Uniformly distributed random rotations for property tests (normalised Gaussian
/// quaternion).

#include <Eigen/Geometry>

#include <random>

namespace brainshift::tests {

inline Eigen::Matrix3d random_rotation(std::mt19937& rng) {
  std::normal_distribution<double> normal;
  Eigen::Quaterniond q(normal(rng), normal(rng), normal(rng), normal(rng));
  return q.normalized().toRotationMatrix();
}

}  // namespace brainshift::tests
