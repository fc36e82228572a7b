#pragma once
/// @file
/// @brief Linear tetrahedral mesh with a material per tetrahedron.
///
/// Glossary: `X` rest positions (#N×3, mm, world RAS), `T` tetrahedra (#T×4 node indices,
/// 0-based, positively oriented: det[X1−X0, X2−X0, X3−X0] > 0), `E` Young's modulus per
/// tetrahedron (kPa), `nu` Poisson ratio per tetrahedron.

#include "core/config.hpp"
#include "core/units.hpp"

#include <array>
#include <optional>
#include <string>
#include <vector>

namespace brainshift::core {

/// Tetrahedral mesh at rest. Holds its data by value; immutable after construction.
class TetMesh {
 public:
  TetMesh() = default;
  /// @param[in] nodes  #N×3 rest positions, mm, world frame.
  /// @param[in] tets   #T×4 node indices, positively oriented.
  /// @param[in] youngs_modulus #T Young's modulus, kPa (empty: brain default 1.5 kPa).
  /// @param[in] poisson_ratio  #T Poisson ratio (empty: default 0.45).
  /// \note Does not validate; call validate() (throws) or find_mesh_issues().
  TetMesh(MatrixX3d nodes, MatrixX4i tets, Eigen::VectorXd youngs_modulus = {},
          Eigen::VectorXd poisson_ratio = {});

  [[nodiscard]] index_t num_nodes() const { return static_cast<index_t>(m_nodes.rows()); }
  [[nodiscard]] index_t num_tets() const { return static_cast<index_t>(m_tets.rows()); }
  [[nodiscard]] const MatrixX3d& nodes() const { return m_nodes; }
  [[nodiscard]] const MatrixX4i& tets() const { return m_tets; }
  [[nodiscard]] const Eigen::VectorXd& youngs_modulus() const { return m_youngs_modulus; }
  [[nodiscard]] const Eigen::VectorXd& poisson_ratio() const { return m_poisson_ratio; }

  /// Rest positions of the four nodes of tetrahedron `t`, rows = nodes (4×3, mm).
  [[nodiscard]] Eigen::Matrix<double, 4, 3> tet_nodes(index_t t) const;
  /// Signed rest volume of tetrahedron `t`, mm³ (positive when correctly oriented).
  [[nodiscard]] double signed_volume(index_t t) const;

 private:
  MatrixX3d m_nodes;
  MatrixX4i m_tets;
  Eigen::VectorXd m_youngs_modulus;
  Eigen::VectorXd m_poisson_ratio;
};

/// Signed volume of the tetrahedron (a, b, c, d): det[b−a, c−a, d−a] / 6 (mm³).
double signed_tet_volume(const Vector3d& a, const Vector3d& b, const Vector3d& c,
                         const Vector3d& d);

/// One problem found by find_mesh_issues().
struct MeshIssue {
  enum class Kind {
    NAN_COORDINATE,       ///< a node has a NaN or infinite coordinate; `index` is the node
    INDEX_OUT_OF_RANGE,   ///< a tetrahedron refers to a node that does not exist; `index` = tet
    REPEATED_NODE,        ///< a tetrahedron uses the same node twice; `index` = tet
    NON_POSITIVE_VOLUME,  ///< zero or negative (inverted) volume; `index` = tet
    UNUSED_NODE,          ///< a node no tetrahedron uses (singular stiffness); `index` = node
    BAD_MATERIAL,         ///< E ≤ 0, nu outside (−1, 0.5), or NaN; `index` = tet
  };
  Kind kind;
  index_t index;
  std::string message;  ///< one line naming the element or node and the values
};

/// Name of an issue kind, e.g. "non-positive volume".
std::string to_string(MeshIssue::Kind kind);

/// All problems of the mesh, in the order listed in MeshIssue::Kind (at most `max_issues`).
std::vector<MeshIssue> find_mesh_issues(const TetMesh& mesh, std::size_t max_issues = 100);

/// Throws brainshift::Error naming the first problem (and how many there are) if the mesh has any.
/// @param[in] what  name of the mesh for the message, e.g. the file name.
void validate(const TetMesh& mesh, const std::string& what = "mesh");

/// Element quality summary.
struct QualityReport {
  index_t num_tets = 0;
  double min_volume = 0.0;        ///< mm³
  double max_volume = 0.0;        ///< mm³
  double min_dihedral_deg = 0.0;  ///< smallest dihedral angle over all tetrahedra, degrees
  double max_dihedral_deg = 0.0;  ///< largest dihedral angle, degrees
  index_t sliver_count = 0;       ///< tetrahedra with a dihedral angle below the sliver threshold
  double sliver_threshold_deg = 0.0;
  index_t worst_tet = -1;  ///< tetrahedron with the smallest dihedral angle
};

/// Dihedral angles of one tetrahedron (6 values, degrees), at its six edges.
std::array<double, 6> dihedral_angles_deg(const Eigen::Matrix<double, 4, 3>& X);

/// Quality report. A tetrahedron is a sliver when its smallest dihedral angle is below
/// `sliver_threshold_deg` (or its largest is above 180° − threshold).
QualityReport quality_report(const TetMesh& mesh, double sliver_threshold_deg = 5.0);

}  // namespace brainshift::core
