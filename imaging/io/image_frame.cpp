#include "imaging/io/image_frame.hpp"

#include <Eigen/SVD>

#include <cmath>
#include <sstream>

namespace brainshift::imaging {

ImageGeometry flip_lps_ras(const ImageGeometry& geometry) {
  ImageGeometry flipped = geometry;
  flipped.origin = lps_ras_flip() * geometry.origin;
  flipped.direction = lps_ras_flip() * geometry.direction;
  return flipped;
}

void flip_vectors_lps_ras(Volume<float>& volume) {
  if (volume.components != 3) return;
  for (std::size_t v = 0; v + 2 < volume.data.size(); v += 3) {
    volume.data[v] = -volume.data[v];
    volume.data[v + 1] = -volume.data[v + 1];
  }
}

double orthonormality_error(const Matrix3d& direction) {
  return (direction.transpose() * direction - Matrix3d::Identity()).cwiseAbs().maxCoeff();
}

void verify_geometry(const ImageGeometry& geometry, const std::string& file) {
  const Eigen::Vector3i& n = geometry.size;
  BS_VERIFY(n.minCoeff() > 0,
            file << ": zero-size image (" << n[0] << "×" << n[1] << "×" << n[2] << " voxels)");
  BS_VERIFY(
      geometry.spacing.allFinite() && geometry.spacing.minCoeff() > 0.0,
      file << ": voxel spacing must be finite and positive, got " << geometry.spacing.transpose());
  BS_VERIFY(geometry.origin.allFinite(),
            file << ": non-finite origin " << geometry.origin.transpose());
  BS_VERIFY(geometry.direction.allFinite(),
            file << ": non-finite direction matrix (rows: " << geometry.direction.row(0) << "; "
                 << geometry.direction.row(1) << "; " << geometry.direction.row(2) << ")");
  const double error = orthonormality_error(geometry.direction);
  BS_VERIFY(std::abs(geometry.direction.determinant()) > 1e-6,
            file << ": direction matrix is singular (determinant "
                 << geometry.direction.determinant() << "; two image axes are parallel)");
  BS_VERIFY(error <= direction_orthonormal_tolerance,
            file << ": direction matrix is not orthonormal (|DᵀD − I| = " << error << " > "
                 << direction_orthonormal_tolerance
                 << "; sheared or scaled grids are not supported)");
}

std::string orthonormalise_direction(ImageGeometry& geometry, const std::string& file) {
  const double error = orthonormality_error(geometry.direction);
  if (error == 0.0) return {};
  const Eigen::JacobiSVD<Matrix3d> svd(geometry.direction,
                                       Eigen::ComputeFullU | Eigen::ComputeFullV);
  geometry.direction = svd.matrixU() * svd.matrixV().transpose();
  if (error <= direction_note_level) return {};
  std::ostringstream note;
  note << file << ": direction matrix orthonormal only to |DᵀD − I| = " << error
       << " (single-precision header); re-orthonormalised (nearest rotation)";
  return note.str();
}

}  // namespace brainshift::imaging
