#pragma once
/// @file
/// @brief Barycentric mapping J (seed 002 eqs. 1–3): each embedded point (collision vertex,
/// vessel skeleton point, landmark) is tied once, at rest, to its containing (or nearest)
/// tetrahedron. J is sparse #M×#N with ≤ 4 weights per row; positions p = J x, forces f = Jᵀ F.

#include "core/config.hpp"
#include "core/mesh/tet_mesh.hpp"

#include <vector>

namespace brainshift::core {

struct MappingOptions {
  /// Points outside the mesh but within this distance (mm) are attached to the nearest
  /// tetrahedron at their projection onto it; farther points are an error.
  double max_outside_distance = 2.0;
};

class BarycentricMapping {
 public:
  BarycentricMapping() = default;
  /// @param[in] mesh rest mesh. @param[in] points #M×3 rest positions of the embedded points, mm.
  /// \throws brainshift::Error naming the first point farther than max_outside_distance from the
  /// mesh (its index, position and distance), or a non-finite point.
  BarycentricMapping(const TetMesh& mesh, ConstRef<MatrixX3d> points,
                     const MappingOptions& options = {});

  [[nodiscard]] index_t num_points() const { return static_cast<index_t>(m_tet.size()); }
  [[nodiscard]] index_t num_nodes() const { return static_cast<index_t>(m_matrix.cols()); }
  /// J: #M×#N sparse scalar weights.
  [[nodiscard]] const SparseMatrix& matrix() const { return m_matrix; }
  /// Tetrahedron each point is tied to.
  [[nodiscard]] const std::vector<index_t>& tet() const { return m_tet; }
  /// Barycentric weights of each point (#M×4, in the order of the tetrahedron's nodes).
  [[nodiscard]] const Eigen::Matrix<double, Eigen::Dynamic, 4, Eigen::RowMajor>& weights() const {
    return m_weights;
  }
  /// Distance of each point from the mesh at rest (0 inside), mm. Points with d > 0 were projected.
  [[nodiscard]] const std::vector<double>& outside_distance() const { return m_outside; }

  /// Mapped positions J x (#M×3) of nodal positions x (#N×3), mm.
  [[nodiscard]] MatrixX3d apply(ConstRef<MatrixX3d> x) const;
  /// Nodal forces Jᵀ F (#N×3) of point forces F (#M×3), mN.
  [[nodiscard]] MatrixX3d apply_transposed(ConstRef<MatrixX3d> F) const;

 private:
  SparseMatrix m_matrix;
  std::vector<index_t> m_tet;
  Eigen::Matrix<double, Eigen::Dynamic, 4, Eigen::RowMajor> m_weights;
  std::vector<double> m_outside;
};

}  // namespace brainshift::core
