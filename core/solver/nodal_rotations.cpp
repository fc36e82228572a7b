#include "core/solver/nodal_rotations.hpp"

#include "core/error.hpp"
#include "core/fem/rotation.hpp"
#include "core/parallel.hpp"

namespace brainshift::core {

std::vector<Matrix3d> nodal_rotations(const TetMesh& mesh,
                                      const std::vector<Matrix3d>& element_rotations) {
  BS_VERIFY(
      static_cast<index_t>(element_rotations.size()) == mesh.num_tets(),
      "got " << element_rotations.size() << " element rotations, expected " << mesh.num_tets());
  const MatrixX4i& T = mesh.tets();
  std::vector<Matrix3d> sum(static_cast<std::size_t>(mesh.num_nodes()), Matrix3d::Zero());
  for (index_t t = 0; t < mesh.num_tets(); ++t) {
    const Matrix3d weighted =
        mesh.signed_volume(t) * element_rotations[static_cast<std::size_t>(t)];
    for (int k = 0; k < 4; ++k) sum[static_cast<std::size_t>(T(t, k))] += weighted;
  }
  // A node without elements (excluded by validate()) gets nearest_rotation(0) = I.
  // The nodes' polar factors are independent: on threads, in fixed blocks (the same result on
  // any number of threads).
  parallel_blocks(sum.size(), 4096, 2, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) sum[i] = nearest_rotation(sum[i]);
  });
  return sum;
}

}  // namespace brainshift::core
