#pragma once
/// @file
/// @brief Pairing (seed 002 §3.4.1): each intra-operative point is paired with its closest
/// feature on the current model — a skeleton segment (point-to-line) or a surface triangle
/// (point-to-plane). A uniform grid over the features' bounding boxes answers nearest-feature
/// queries by expanding rings of cells. Positions in mm, world frame.

#include "core/config.hpp"
#include "core/geometry/skeleton.hpp"

#include <optional>
#include <vector>

namespace brainshift::constraints {

/// One intra-operative point paired with a model feature.
struct Pair {
  index_t point = -1;    ///< index of the intra-operative point
  index_t feature = -1;  ///< segment or triangle index
  Vector3d weights =
      Vector3d::Zero();  ///< closest point as weights of the feature's 2 or 3 vertices
  Vector3d closest = Vector3d::Zero();    ///< closest point on the feature, mm
  Vector3d direction = Vector3d::Zero();  ///< unit tangent (segment) or unit normal (triangle)
  double distance = 0.0;                  ///< |point − closest|, mm
};

/// Nearest-feature index over segments (2 vertices each) or triangles (3 vertices each).
/// Holds a copy of the vertex positions; rebuild when they move.
class FeatureIndex {
 public:
  /// Segments of a skeleton at the given vertex positions (#P×3).
  static FeatureIndex segments(ConstRef<MatrixX3d> vertices,
                               const std::vector<std::array<index_t, 2>>& segments);
  /// Triangles at the given vertex positions (#V×3).
  static FeatureIndex triangles(
      ConstRef<MatrixX3d> vertices,
      const Eigen::Matrix<index_t, Eigen::Dynamic, 3, Eigen::RowMajor>& tris);

  [[nodiscard]] index_t size() const { return static_cast<index_t>(m_features.size()); }
  /// Closest feature to q within max_distance (mm), or nullopt.
  [[nodiscard]] std::optional<Pair> nearest(const Vector3d& q, double max_distance) const;
  /// Closest feature of every query point within max_distance (points with none are left out).
  [[nodiscard]] std::vector<Pair> pair(ConstRef<MatrixX3d> queries, double max_distance) const;
  /// q paired with the given feature f (closest point on it), whatever its distance.
  [[nodiscard]] Pair closest_on(index_t f, const Vector3d& q) const;

 private:
  FeatureIndex(ConstRef<MatrixX3d> vertices, std::vector<std::array<index_t, 3>> features,
               int arity);
  MatrixX3d m_vertices;
  std::vector<std::array<index_t, 3>> m_features;
  int m_arity = 2;
  Vector3d m_origin = Vector3d::Zero();
  double m_cell = 1.0;
  Eigen::Vector3i m_dims = Eigen::Vector3i::Ones();
  std::vector<index_t> m_cell_start;
  std::vector<index_t> m_cell_features;
};

}  // namespace brainshift::constraints
