#pragma once
/// @file
/// @brief Voxel volumes with their world geometry. World = scanner frame, RAS, millimetres
/// (the NIfTI convention); every reader converts into it and every writer converts out of it.
///
/// Voxel (i, j, k) has its centre at world point  p = origin + direction · diag(spacing) · (i, j,
/// k)ᵀ. Data are stored with i fastest, then j, then k (the NIfTI / VTK order).

#include "core/config.hpp"
#include "core/error.hpp"

#include <cstdint>
#include <vector>

namespace brainshift::imaging {

/// Where a voxel grid sits in the world (RAS, mm).
struct ImageGeometry {
  Eigen::Vector3i size{0, 0, 0};              ///< voxels along i, j, k
  Vector3d origin = Vector3d::Zero();         ///< world position of voxel (0,0,0)'s centre, mm
  Vector3d spacing = Vector3d::Ones();        ///< voxel size along i, j, k, mm, > 0
  Matrix3d direction = Matrix3d::Identity();  ///< columns: world unit vectors of i, j, k

  [[nodiscard]] std::int64_t voxel_count() const {
    return std::int64_t(size[0]) * size[1] * size[2];
  }
  /// Linear index of voxel (i, j, k), i fastest.
  [[nodiscard]] std::int64_t linear_index(int i, int j, int k) const {
    return (std::int64_t(k) * size[1] + j) * size[0] + i;
  }
  [[nodiscard]] bool contains_index(int i, int j, int k) const {
    return i >= 0 && j >= 0 && k >= 0 && i < size[0] && j < size[1] && k < size[2];
  }
  /// Continuous index (i, j, k) → world RAS mm.
  [[nodiscard]] Vector3d index_to_world(const Vector3d& ijk) const {
    return origin + direction * spacing.cwiseProduct(ijk);
  }
  /// World RAS mm → continuous index (i, j, k); voxel centres are at integers.
  [[nodiscard]] Vector3d world_to_index(const Vector3d& p) const {
    return (direction.transpose() * (p - origin)).cwiseQuotient(spacing);
  }
  /// 4×4 homogeneous index → world matrix (the NIfTI sform in RAS).
  [[nodiscard]] Eigen::Matrix4d index_to_world_matrix() const {
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    m.topLeftCorner<3, 3>() = direction * spacing.asDiagonal();
    m.topRightCorner<3, 1>() = origin;
    return m;
  }
};

/// A scalar or vector volume: `components` values per voxel, interleaved (voxel-major).
template <typename T>
struct Volume {
  ImageGeometry geometry;
  int components = 1;
  std::vector<T> data;  ///< voxel_count() × components values

  Volume() = default;
  explicit Volume(const ImageGeometry& g, int n_components = 1, T fill = T{})
      : geometry(g),
        components(n_components),
        data(std::size_t(g.voxel_count()) * std::size_t(n_components), fill) {
    BS_VERIFY(n_components >= 1, "a volume needs at least one component, got " << n_components);
  }

  [[nodiscard]] T& at(int i, int j, int k, int c = 0) {
    return data[std::size_t(geometry.linear_index(i, j, k) * components + c)];
  }
  [[nodiscard]] const T& at(int i, int j, int k, int c = 0) const {
    return data[std::size_t(geometry.linear_index(i, j, k) * components + c)];
  }
  [[nodiscard]] bool empty() const { return data.empty(); }
};

using VolumeF = Volume<float>;  ///< intensities (MRI, MRA, Doppler, B-mode), displacement fields
using LabelVolume = Volume<std::uint8_t>;  ///< 0 background, 1 brain, 2 tumour, 3 ventricles (CSF)

/// Label values used everywhere (phantoms, `prepare`, tests).
enum Label : std::uint8_t { BACKGROUND = 0, BRAIN = 1, TUMOUR = 2, VENTRICLES = 3 };

}  // namespace brainshift::imaging
