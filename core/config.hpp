#pragma once
/// @file
/// @brief Scalar and index types and small Eigen aliases shared by every module.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <Eigen/SparseCore>

namespace brainshift {

using index_t = int;  ///< node, element, row and DOF indices (CHOLMOD int interface)
using scalar = double;

using Vector3d = Eigen::Vector3d;
using Vector4d = Eigen::Vector4d;
using Vector12d = Eigen::Matrix<double, 12, 1>;
using Matrix3d = Eigen::Matrix3d;
using Matrix12d = Eigen::Matrix<double, 12, 12>;
using MatrixX3d = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;
using MatrixX4i = Eigen::Matrix<index_t, Eigen::Dynamic, 4, Eigen::RowMajor>;
using SparseMatrix = Eigen::SparseMatrix<double, Eigen::ColMajor, index_t>;
using Triplet = Eigen::Triplet<double, index_t>;

/// Read-only view of any Eigen expression without a copy (IPC's `ConstRef`).
template <typename T>
using ConstRef = const Eigen::Ref<const T>&;

}  // namespace brainshift
