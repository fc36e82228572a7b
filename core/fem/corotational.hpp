#pragma once
/// @file
/// @brief Corotational linear tetrahedral FEM (Felippa; Nesme et al. 2005; seed 002 §3.3.1).
///
/// Per element e with rest nodes X_e, current nodes x_e (12-vectors) and rotation R_e (the
/// polar-decomposition rotation of F_e = Ds Dm⁻¹):
///   internal force  f_e = R̂_e K_e (R̂_eᵀ x_e − X_e),   rotated stiffness  R̂_e K_e R̂_eᵀ,
/// where R̂_e = diag(R_e, R_e, R_e, R_e). Sign convention: f is the elastic force *on* the nodes'
/// resistance, i.e. f_int = ∂Ψ/∂x; equilibrium is f_int = f_ext.

#include "core/config.hpp"
#include "core/fem/linear_tet.hpp"
#include "core/mesh/tet_mesh.hpp"

#include <cstdint>
#include <vector>

namespace brainshift::core {

/// Per-element rotations of a configuration, and how many elements were inverted.
struct ElementRotations {
  std::vector<Matrix3d> rotation;  ///< #T proper rotations (det = +1)
  index_t inverted_count = 0;      ///< elements with det F ≤ 0 in this configuration
};

/// A pre-strained elastic rest: the state in which the elements carry no stress, other than the
/// mesh's rest shape. The element stiffnesses stay the mesh's (the rest is a small-strain offset
/// of it); only the rotations and the forces are measured from it, so at x = nodes every
/// rotation is the identity and the internal force is zero. Used for a load whose linear
/// response is known (the bulk shift, constraints/registration): the corotational iteration then
/// starts at that load's equilibrium instead of carrying a large body force, which it cannot
/// converge under (the missing geometric stiffness; docs/history/BENCHMARKS_NOTEBOOK.md).
struct RestShape {
  MatrixX3d nodes;                      ///< #N×3, mm, world
  std::vector<Matrix3d> edges_inv;      ///< per tet: Dm⁻¹ of these nodes (1/mm)
  std::vector<std::uint8_t> mesh_rest;  ///< per tet: 1 = keeps the mesh's rest (degenerate here)
  index_t degenerate = 0;  ///< tets flat or inverted in `nodes`: they keep the mesh's rest
};

/// Precomputed corotational model of a mesh: shapes and linear element stiffnesses.
class CorotationalModel {
 public:
  /// Precomputes shapes and K_e. \throws brainshift::Error if the mesh is invalid (validate()).
  explicit CorotationalModel(const TetMesh& mesh);

  [[nodiscard]] const TetMesh& mesh() const { return m_mesh; }
  [[nodiscard]] const std::vector<TetShape>& shapes() const { return m_shapes; }
  [[nodiscard]] const std::vector<Matrix12d>& element_stiffness() const { return m_stiffness; }

  /// Element rotations at current positions x (#N×3, mm), from the mesh's rest or from `rest`.
  /// \throws brainshift::Error if x has the wrong size or a non-finite entry (names the node).
  [[nodiscard]] ElementRotations element_rotations(ConstRef<MatrixX3d> x,
                                                   const RestShape* rest = nullptr) const;

  /// Internal elastic force (3N, node-major x0,y0,z0,x1,…; mN) at positions x with the given
  /// element rotations, from the mesh's rest or from `rest`.
  [[nodiscard]] Eigen::VectorXd internal_force(ConstRef<MatrixX3d> x,
                                               const std::vector<Matrix3d>& rotations,
                                               const RestShape* rest = nullptr) const;

  /// The pre-strained rest at `nodes` (#N×3, mm). A tet whose volume there is not at least
  /// 1e-3 of its mesh volume (flat or inverted) keeps the mesh's rest; RestShape::degenerate
  /// counts them. \throws brainshift::Error on a wrong size or a non-finite node.
  [[nodiscard]] RestShape rest_shape(ConstRef<MatrixX3d> nodes) const;

  /// Consistent gravity load: each element's weight ρ V g split equally over its 4 nodes
  /// (3N, mN). @param[in] gravity mm/s²  @param[in] density kg/mm³.
  [[nodiscard]] Eigen::VectorXd gravity_force(const Vector3d& gravity, double density) const;

 private:
  TetMesh m_mesh;
  std::vector<TetShape> m_shapes;
  std::vector<Matrix12d> m_stiffness;
};

}  // namespace brainshift::core
