#pragma once
/// @file
/// @brief Constraint rows (seed 002 §3.3.2, §3.4.3). A row i is a direction nᵢ (unit, world),
/// a stencil pᵢ(x) = Σₖ wₖ x_{nodeₖ} (a barycentrically mapped point, or a point on a segment
/// between two mapped points) and a target offset, giving the constraint value
///   gᵢ(x) = nᵢ · pᵢ(x) − cᵢ     (mm; the violation δᵢ is gᵢ at the current positions),
/// and its row of the constraint Jacobian Hᵢ = nᵢᵀ Jᵢ (1×3N).
/// Laws: BILATERAL gᵢ = 0, λᵢ free; UNILATERAL gᵢ ≥ 0, λᵢ ≥ 0, gᵢ λᵢ = 0. A positive λᵢ
/// pushes pᵢ along +nᵢ (constraint force Hᵀλ, mN).
///
/// | kind                | rows | law        | directions                                   |
/// |---------------------|------|------------|----------------------------------------------|
/// | bilateral point     | 3    | bilateral  | world axes                                   |
/// | sliding on a line   | 2    | bilateral  | normals to the line (free along it)          |
/// | sliding on a plane  | 1    | bilateral  | plane normal (free in the plane)             |
/// | unilateral on plane | 1    | unilateral | plane normal, pointing to the allowed side   |

#include "core/config.hpp"

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace brainshift::constraints {

/// Which constraint set a row belongs to (reports, filtering, per-set switches).
enum class ConstraintSet : std::uint8_t { VESSELS, FOOTPRINT, DURA, FIXED, LANDMARK };
inline constexpr int num_constraint_sets = 5;
std::string to_string(ConstraintSet set);

enum class ConstraintKind : std::uint8_t {
  BILATERAL_POINT,
  SLIDING_LINE,
  SLIDING_PLANE,
  UNILATERAL_PLANE
};
std::string to_string(ConstraintKind kind);

enum class ConstraintLaw : std::uint8_t { BILATERAL, UNILATERAL };

/// A point of the model as a weighted sum of nodes: one mapped vertex (≤ 4 nodes), a point on a
/// segment between two mapped vertices (≤ 8 nodes) or on a triangle of three (≤ 12 nodes).
/// Weights sum to 1.
struct Stencil {
  static constexpr int capacity = 12;
  std::array<index_t, capacity> node{};
  std::array<double, capacity> weight{};
  int size = 0;

  /// Appends (node, w); merges repeated nodes. \throws brainshift::Error past capacity.
  void add(index_t n, double w);
  /// Position Σ wₖ x_{nodeₖ} for nodal positions x (#N×3, mm).
  [[nodiscard]] Vector3d position(ConstRef<MatrixX3d> x) const;
  /// (1 − t)·a + t·b.
  static Stencil interpolate(const Stencil& a, const Stencil& b, double t);
  /// wa·a + wb·b + wc·c (barycentric weights of a triangle).
  static Stencil combine(const Stencil& a, const Stencil& b, const Stencil& c, const Vector3d& w);
};

/// One scalar constraint row.
struct ConstraintRow {
  Stencil stencil;
  Vector3d direction = Vector3d::UnitX();  ///< unit, world frame
  double offset = 0.0;                     ///< cᵢ = nᵢ·target, mm
  double violation = 0.0;  ///< δᵢ = gᵢ(x) at the positions the rows were built at, mm
  ConstraintLaw law = ConstraintLaw::BILATERAL;
  ConstraintKind kind = ConstraintKind::BILATERAL_POINT;
  ConstraintSet set = ConstraintSet::VESSELS;
  index_t group = 0;          ///< rows of one constraint share a group (solved as a block by PGS)
  std::int64_t feature = -1;  ///< model feature id (segment / triangle / vertex) for warm starts
};

/// An ordered set of rows; groups are contiguous.
class ConstraintRows {
 public:
  /// 3 bilateral rows along the world axes: p(x) = target. Returns the group id.
  index_t add_bilateral_point(const Stencil& s, ConstRef<MatrixX3d> x, const Vector3d& target,
                              ConstraintSet set, std::int64_t feature = -1);
  /// 2 bilateral rows normal to `tangent`: p(x) lies on the line through `target` along `tangent`
  /// (free along it). The first normal points from the target's projection towards p when they
  /// differ. \throws brainshift::Error when `tangent` is zero or not finite.
  index_t add_sliding_line(const Stencil& s, ConstRef<MatrixX3d> x, const Vector3d& target,
                           const Vector3d& tangent, ConstraintSet set, std::int64_t feature = -1);
  /// 1 bilateral row along `normal`: p(x) lies on the plane through `target` (free in it).
  index_t add_sliding_plane(const Stencil& s, ConstRef<MatrixX3d> x, const Vector3d& target,
                            const Vector3d& normal, ConstraintSet set, std::int64_t feature = -1);
  /// 1 unilateral row: n·(p(x) − target) ≥ 0, with `normal` pointing to the allowed side.
  index_t add_unilateral_plane(const Stencil& s, ConstRef<MatrixX3d> x, const Vector3d& target,
                               const Vector3d& normal, ConstraintSet set,
                               std::int64_t feature = -1);

  [[nodiscard]] index_t size() const { return static_cast<index_t>(m_rows.size()); }
  [[nodiscard]] bool empty() const { return m_rows.empty(); }
  [[nodiscard]] index_t num_groups() const { return m_num_groups; }
  [[nodiscard]] const std::vector<ConstraintRow>& rows() const { return m_rows; }
  [[nodiscard]] const ConstraintRow& operator[](index_t i) const { return m_rows[i]; }
  void clear();

  /// Constraint Jacobian H (#rows × 3N, node-major DOFs).
  [[nodiscard]] SparseMatrix jacobian(index_t num_nodes) const;
  /// Violations δ (#rows, mm) as stored at build time.
  [[nodiscard]] Eigen::VectorXd violations() const;
  /// Constraint values g(x) (#rows, mm) at other positions x.
  [[nodiscard]] Eigen::VectorXd values(ConstRef<MatrixX3d> x) const;
  /// Rows per constraint set.
  [[nodiscard]] std::array<index_t, num_constraint_sets> count_by_set() const;

 private:
  index_t add_row(const Stencil& s, ConstRef<MatrixX3d> x, const Vector3d& n,
                  const Vector3d& target, ConstraintLaw law, ConstraintKind kind, ConstraintSet set,
                  std::int64_t feature);
  std::vector<ConstraintRow> m_rows;
  index_t m_num_groups = 0;
};

}  // namespace brainshift::constraints
