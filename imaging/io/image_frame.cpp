#include "imaging/io/image_frame.hpp"

#include <cmath>

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

void verify_geometry(const ImageGeometry& geometry, const std::string& file) {
  // Float headers (NIfTI, VTK) store directions to ~1e-7; hand-edited ones to a few digits.
  constexpr double orthonormal_tolerance = 1e-3;
  const Eigen::Vector3i& n = geometry.size;
  BS_VERIFY(n.minCoeff() > 0, file << ": zero-size image (" << n[0] << "×" << n[1] << "×" << n[2]
                                   << " voxels)");
  BS_VERIFY(geometry.spacing.allFinite() && geometry.spacing.minCoeff() > 0.0,
            file << ": voxel spacing must be finite and positive, got "
                 << geometry.spacing.transpose());
  BS_VERIFY(geometry.origin.allFinite(), file << ": non-finite origin "
                                              << geometry.origin.transpose());
  BS_VERIFY(geometry.direction.allFinite(),
            file << ": non-finite direction matrix (rows: "
                 << geometry.direction.row(0) << "; " << geometry.direction.row(1) << "; "
                 << geometry.direction.row(2) << ")");
  const double error =
      (geometry.direction.transpose() * geometry.direction - Matrix3d::Identity()).cwiseAbs().maxCoeff();
  BS_VERIFY(error <= orthonormal_tolerance,
            file << ": direction matrix is not orthonormal (|DᵀD − I| = " << error
                 << "; sheared or scaled grids are not supported)");
}

}  // namespace brainshift::imaging
