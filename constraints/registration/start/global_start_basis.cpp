#include "constraints/registration/start/global_start.hpp"
#include "constraints/registration/start/nearest_node.hpp"
#include "core/mesh/tet_mesh.hpp"

#include <cmath>
#include <sstream>
#include <vector>

// The global start's options check and its bulk-response basis (global_start.hpp).
namespace brainshift::constraints {

std::string GlobalStartOptions::validate() const {
  std::ostringstream os;
  if (!(max_translation_mm >= 0 && max_translation_mm <= 200))
    os << "max_translation_mm must be in [0, 200]; ";
  if (!(max_rotation_deg >= 0 && max_rotation_deg <= 30))
    os << "max_rotation_deg must be in [0, 30]; ";
  if (!(coarse_kernel_mm > 0 && coarse_step_mm > 0 && coarse_step_mm <= coarse_kernel_mm))
    os << "need 0 < coarse_step_mm ≤ coarse_kernel_mm; ";
  if (!(fine_kernel_mm > 0 && fine_kernel_mm <= coarse_kernel_mm))
    os << "need 0 < fine_kernel_mm ≤ coarse_kernel_mm; ";
  if (!(refine_distance_mm > 0 && refine_distance_mm <= coarse_kernel_mm))
    os << "need 0 < refine_distance_mm ≤ coarse_kernel_mm; ";
  if (!(voxel_mm > 0)) os << "voxel_mm must be > 0; ";
  if (coarse_points < 1 || max_points < 1 || candidates < 1)
    os << "coarse_points, max_points, candidates must be ≥ 1; ";
  if (min_points < 3) os << "min_points must be ≥ 3; ";
  if (!(min_gain >= 1)) os << "min_gain must be ≥ 1; ";
  if (!(significance_z >= 0) || !(significance_block_mm > 0))
    os << "significance_z must be ≥ 0 and significance_block_mm > 0; ";
  if (!(loss_scale_mm > 0) || !(convergence_mm > 0))
    os << "loss_scale_mm and convergence_mm must be > 0; ";
  if (refine_iterations < 0 || solver_iterations < 1)
    os << "refine_iterations ≥ 0 and solver_iterations ≥ 1 needed; ";
  if (!(navigation_accuracy_mm >= 0 && navigation_accuracy_mm <= 100))
    os << "navigation_accuracy_mm must be in [0, 100]; ";
  if (!(bulk_prior_mm > 0) || !(bulk_min_mm >= 0))
    os << "bulk_prior_mm must be > 0 and bulk_min_mm ≥ 0; ";
  if (!(ambiguity_ratio > 0) || !(ambiguity_distance_mm > 0) || !(min_spread_mm >= 0))
    os << "ambiguity_ratio and ambiguity_distance_mm must be > 0, min_spread_mm ≥ 0; ";
  const std::string s = os.str();
  return s.empty() ? bulk_search.validate() : "global start: " + s.substr(0, s.size() - 2);
}

Matrix3d load_response_at(const std::array<MatrixX3d, 3>& response, Eigen::Index node) {
  Matrix3d r;
  for (Eigen::Index k = 0; k < 3; ++k)
    r.col(k) = response[static_cast<std::size_t>(k)].row(node).transpose();
  return r;
}

Matrix3d mean_load_response(const core::TetMesh& mesh, const std::array<MatrixX3d, 3>& response,
                            ConstRef<MatrixX3d> points) {
  Matrix3d mean = Matrix3d::Zero();
  if (points.rows() == 0) return mean;
  const NearestNode nearest(mesh.nodes());
  for (Eigen::Index i = 0; i < points.rows(); ++i)
    mean += load_response_at(response, nearest.nearest(points.row(i).transpose())) /
            static_cast<double>(points.rows());
  return mean;
}

std::vector<Matrix3d> load_basis(const core::TetMesh& mesh,
                                 const std::array<MatrixX3d, 3>& response,
                                 ConstRef<MatrixX3d> points) {
  if (points.rows() == 0) return {};
  std::vector<Matrix3d> basis(static_cast<std::size_t>(points.rows()));
  Matrix3d mean = Matrix3d::Zero();
  const NearestNode nearest(mesh.nodes());
  for (Eigen::Index i = 0; i < points.rows(); ++i) {
    basis[static_cast<std::size_t>(i)] =
        load_response_at(response, nearest.nearest(points.row(i).transpose()));
    mean += basis[static_cast<std::size_t>(i)] / static_cast<double>(points.rows());
  }
  if (!(std::abs(mean.determinant()) > 1e-9 * std::pow(mean.norm(), 3))) return {};
  const Matrix3d inv = mean.inverse();
  for (Matrix3d& b : basis) b = b * inv;
  return basis;
}

}  // namespace brainshift::constraints
