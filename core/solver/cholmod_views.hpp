#pragma once
/// @file
/// @brief Views (no copies) of Eigen matrices as CHOLMOD's structs, for core/solver's .cpp files
/// only (CHOLMOD is a private dependency of brainshift_core: never include this from a public
/// header).

#include "core/config.hpp"
#include "core/error.hpp"

#include <cholmod.h>

namespace brainshift::core::detail {

/// The lower triangle of a square A in compressed, sorted form, owning the storage a view needs.
inline SparseMatrix lower_triangle(const SparseMatrix& A) {
  SparseMatrix L = A.triangularView<Eigen::Lower>();
  L.makeCompressed();
  return L;
}

/// A cholmod_sparse view (no copy) of a compressed Eigen matrix; stype −1 reads its lower
/// triangle as a symmetric matrix, 0 reads it as unsymmetric. `M` must outlive the view.
inline cholmod_sparse sparse_view(SparseMatrix& M, int stype) {
  BS_ASSERT(M.isCompressed(), "sparse view needs a compressed matrix");
  cholmod_sparse v{};
  v.nrow = static_cast<std::size_t>(M.rows());
  v.ncol = static_cast<std::size_t>(M.cols());
  v.nzmax = static_cast<std::size_t>(M.nonZeros());
  v.p = M.outerIndexPtr();
  v.i = M.innerIndexPtr();
  v.nz = nullptr;
  v.x = M.valuePtr();
  v.z = nullptr;
  v.stype = stype;
  v.itype = CHOLMOD_INT;
  v.xtype = CHOLMOD_REAL;
  v.dtype = CHOLMOD_DOUBLE;
  v.sorted = 1;
  v.packed = 1;
  return v;
}

}  // namespace brainshift::core::detail
