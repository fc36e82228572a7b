#include "core/assembly/stiffness_assembly.hpp"

#include "core/error.hpp"

namespace brainshift::core {

namespace {

/// Σ_e Aᵀ (R̂_e K_e R̂_eᵀ) A; identity rotations when `rotations` is null.
SparseMatrix assemble(const CorotationalModel& model, const std::vector<Matrix3d>* rotations) {
  const TetMesh& mesh = model.mesh();
  const MatrixX4i& T = mesh.tets();
  const index_t nt = mesh.num_tets();
  std::vector<Triplet> triplets;
  triplets.reserve(static_cast<std::size_t>(nt) * 144);
  for (index_t t = 0; t < nt; ++t) {
    Matrix12d K = model.element_stiffness()[static_cast<std::size_t>(t)];
    if (rotations != nullptr) {
      Matrix12d Rhat = Matrix12d::Zero();
      for (int k = 0; k < 4; ++k) {
        Rhat.block<3, 3>(3 * k, 3 * k) = (*rotations)[static_cast<std::size_t>(t)];
      }
      K = Rhat * K * Rhat.transpose();
    }
    for (int a = 0; a < 4; ++a) {
      for (int b = 0; b < 4; ++b) {
        for (int i = 0; i < 3; ++i) {
          for (int j = 0; j < 3; ++j) {
            triplets.emplace_back(3 * T(t, a) + i, 3 * T(t, b) + j, K(3 * a + i, 3 * b + j));
          }
        }
      }
    }
  }
  const index_t n = 3 * mesh.num_nodes();
  SparseMatrix K(n, n);
  K.setFromTriplets(triplets.begin(), triplets.end());
  return K;
}

}  // namespace

SparseMatrix assemble_rest_stiffness(const CorotationalModel& model) {
  return assemble(model, nullptr);
}

SparseMatrix assemble_rotated_stiffness(const CorotationalModel& model,
                                        const std::vector<Matrix3d>& element_rotations) {
  BS_VERIFY(static_cast<index_t>(element_rotations.size()) == model.mesh().num_tets(),
            "got " << element_rotations.size() << " element rotations, expected "
                   << model.mesh().num_tets());
  return assemble(model, &element_rotations);
}

}  // namespace brainshift::core
