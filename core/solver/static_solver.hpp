#pragma once
/// @file
/// @brief Static forward solve of the corotational model under prescribed displacements and body
/// forces: iterate  x ← x + R K0⁻¹ Rᵀ (f_ext − f_int(x))  on the free DOFs (quasi-Newton with the
/// warped pre-factorised rest stiffness) until the increment is below a tolerance. At small strain
/// the first iteration is the linear FEM solution.

#include "core/assembly/dof_map.hpp"
#include "core/config.hpp"
#include "core/fem/corotational.hpp"
#include "core/solver/cholmod_factor.hpp"

#include <string>
#include <vector>

namespace brainshift::core {

/// A node with a prescribed displacement (mm, world frame).
struct PrescribedDisplacement {
  index_t node = -1;
  Vector3d displacement = Vector3d::Zero();
};

struct StaticOptions {
  int max_iterations = 200;             ///< cap on corotational iterations
  double increment_tolerance = 1e-6;    ///< stop when max nodal |Δx| < this × max(1 mm, max |u|)
  Vector3d gravity = Vector3d::Zero();  ///< body acceleration, mm/s² (e.g. (0, 0, −9810))
  double density = 1040e-9;             ///< kg/mm³ (brain ≈ 1040 kg/m³)
  bool corotational = true;             ///< false: plain linear FEM (one solve, no rotations)
  /// Empty when valid, else the reason.
  [[nodiscard]] std::string validate() const;
};

enum class SolveStatus {
  CONVERGED,
  MAX_ITERATIONS,  ///< cap reached; result is the last finite iterate
  DIVERGED,        ///< the increment grew without bound or became non-finite; last finite iterate
  FACTOR_FAILED,   ///< K0_ff could not be factorised (under-constrained model)
};
std::string to_string(SolveStatus status);

struct StaticResult {
  SolveStatus status = SolveStatus::FACTOR_FAILED;
  std::string message;     ///< one line: why it stopped
  MatrixX3d displacement;  ///< #N×3, mm
  int iterations = 0;
  double final_increment = 0.0;  ///< max nodal |Δx| of the last iteration, mm
  /// ‖f_ext − f_int‖ on free DOFs / ‖f_ext,total‖, dimensionless; the total load is
  /// max(‖f_ext‖, ‖f_int‖) over all DOFs, so the reactions of the Dirichlet nodes count.
  double final_residual = 0.0;
  std::vector<double> increment_history;
  index_t inverted_elements = 0;  ///< in the final configuration
};

/// Prepared forward solver: K0 assembled, Dirichlet nodes eliminated, CHOLMOD factor computed
/// once in the constructor and reused by every solve().
class StaticSolver {
 public:
  /// @param[in] mesh  validated here. @param[in] dirichlet_nodes nodes whose displacement is
  /// imposed (fixed ones and prescribed ones alike).
  StaticSolver(const TetMesh& mesh, const std::vector<index_t>& dirichlet_nodes);

  /// Solve with prescribed displacements on (a subset of) the Dirichlet nodes; Dirichlet nodes
  /// not listed stay fixed. \throws brainshift::Error if a prescribed node is not a Dirichlet node
  /// or a value is not finite.
  [[nodiscard]] StaticResult solve(const std::vector<PrescribedDisplacement>& prescribed,
                                   const StaticOptions& options) const;

  [[nodiscard]] const CorotationalModel& model() const { return m_model; }
  [[nodiscard]] const DofMap& dofs() const { return m_dofs; }
  [[nodiscard]] const CholmodFactor& factor() const { return m_factor; }

 private:
  CorotationalModel m_model;
  DofMap m_dofs;
  CholmodFactor m_factor;
  /// Non-empty when the Dirichlet nodes cannot remove the rigid modes (fewer than 3 distinct
  /// nodes, or all on one line): the model is under-constrained and K0_ff is not factorised,
  /// because a singular K0_ff may factorise with tiny positive pivots instead of failing.
  std::string m_underconstrained;
};

}  // namespace brainshift::core
