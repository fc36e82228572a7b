#pragma once
/// @file
/// @brief The Delassus operator W = H R K0⁻¹ Rᵀ Hᵀ (compliance warping, seed 002 §3.3.3) with two
/// strategies (ARCHITECTURE.md, "W is the hot spot"):
///  (a) DENSE_BLOCK: C = K0_ff⁻¹ restricted to the DOFs of the nodes any collision vertex can map
///      to, precomputed once before surgery (3|S| solves); then W = G C Gᵀ with G = H R restricted
///      to those nodes, a small dense product per iteration;
///  (b) SPARSE_SOLVE: per iteration Y = L⁻¹ P (H R)ᵀ with sparse right-hand sides (CHOLMOD), W = Yᵀ
///  Y.
/// AUTO picks (a) when the block fits the memory budget, else (b); a call whose rows touch a node
/// outside the block falls back to (b) for that call.
///
/// The block is the expensive part of preparing a model (3|S| solves: seconds at 20k nodes), so it
/// can be computed once before surgery, saved (apps/workflow/compliance_cache.hpp) and handed back
/// through ComplianceOptions::precomputed. It is adopted only when it provably belongs to this
/// model: same stiffness fingerprint (mesh, materials, fixed nodes), same block nodes, finite, and
/// two of its columns agree with fresh solves; otherwise it is recomputed and cache_status() says
/// why.

#include "core/assembly/dof_map.hpp"
#include "core/config.hpp"
#include "core/fem/corotational.hpp"
#include "core/option_fields.hpp"
#include "core/solver/cholmod_factor.hpp"
#include "core/solver/warped_compliance.hpp"

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace brainshift::constraints {

enum class ComplianceStrategy { AUTO, DENSE_BLOCK, SPARSE_SOLVE };
std::string to_string(ComplianceStrategy s);
/// Names of ComplianceStrategy in the scene, reports and the command line.
constexpr std::array<core::EnumName<ComplianceStrategy>, 3> enum_names(ComplianceStrategy /*tag*/) {
  return {{{ComplianceStrategy::AUTO, "auto"},
           {ComplianceStrategy::DENSE_BLOCK, "dense_block"},
           {ComplianceStrategy::SPARSE_SOLVE, "sparse_solve"}}};
}

/// How the dense block C = K0_ff⁻¹ (block DOFs) is computed when it is not adopted from a cache.
enum class BlockPrecompute {
  /// The partial factorisation when the block holds at most a quarter of the free DOFs, else
  /// unit solves. Measured (prepare on `standard`, CPU time): at 17k nodes (block 9 % of the
  /// DOFs) the partial factorisation is 2.5× cheaper; at 1.6k nodes (block 50 %) its dense
  /// inverse of half the matrix costs more than the solves (4.6 against 3.8 s for all of prepare).
  AUTO,
  /// One factorisation with the block DOFs last (core/solver/inverse_block).
  PARTIAL_FACTORISATION,
  UNIT_SOLVES,  ///< one solve per block DOF with the factor
};
std::string to_string(BlockPrecompute m);
constexpr std::array<core::EnumName<BlockPrecompute>, 3> enum_names(BlockPrecompute /*tag*/) {
  return {{{BlockPrecompute::AUTO, "auto"},
           {BlockPrecompute::PARTIAL_FACTORISATION, "partial_factorisation"},
           {BlockPrecompute::UNIT_SOLVES, "unit_solves"}}};
}

/// A precomputed dense compliance block C = K0_ff⁻¹ on the DOFs of `nodes` (mm/mN).
struct ComplianceBlock {
  std::uint64_t fingerprint = 0;  ///< stiffness_fingerprint() of the model it was computed for
  std::vector<index_t> nodes;     ///< sorted, unique
  Eigen::MatrixXd matrix;         ///< (3|nodes|)², symmetric, zero rows/columns on fixed DOFs
};

/// 64-bit FNV-1a over everything K0_ff depends on: node coordinates, tetrahedra, per-element
/// Young's modulus and Poisson ratio, and the fixed nodes (sorted). Not cryptographic: it tells a
/// stale cache from a current one.
std::uint64_t stiffness_fingerprint(const core::TetMesh& mesh, std::vector<index_t> fixed_nodes);

struct ComplianceOptions {
  ComplianceStrategy strategy = ComplianceStrategy::AUTO;
  std::size_t memory_budget_bytes = std::size_t{512}
                                    << 20;  ///< for the dense block (default 512 MiB)
  /// How the block is computed (the partial factorisation needs the factorised matrix:
  /// ComplianceOperator's `factorised`; without it, unit solves).
  BlockPrecompute precompute = BlockPrecompute::AUTO;
  int precompute_chunk = 64;  ///< right-hand sides per CHOLMOD solve when precomputing the block
  /// Threads solving chunks at once when precomputing the block (≥ 1; each chunk is solved as
  /// with one thread, so the block is the same bit for bit).
  int precompute_threads = 2;
  /// A block saved by an earlier preparation of the same model (checked before it is used).
  std::shared_ptr<const ComplianceBlock> precomputed;
  /// apply(v, R), the registration's free motion and correction, solves with a float copy of L
  /// (core::SingleFactor) when L's values in double take at least `single_precision_min_bytes`:
  /// such a solve is bound by reading L, and float halves that traffic (20,841 nodes, 293 MiB:
  /// 4.96 → 3.06 s a registration; 4,126 nodes, 22 MiB: 0.467 → 0.361 s). A small L stays in
  /// the caches and its solve is a small share of a step (1,614 nodes, 5 MiB: 0.136 s either
  /// way), so the double solve is kept there. The float error is about
  /// 1e-6 relative; each step's residual, W and the block stay in double, so the loop's fixed
  /// points are the double solve's and the error moves the path only (docs/BENCHMARKS.md,
  /// "Single-precision solves"). Not scene keys (a numerical method, like the precompute
  /// method); false: CHOLMOD's double solve everywhere.
  bool single_precision_solves = true;
  /// 16 MiB: half the 2-core VM's 32 MiB L3, which its two cores and the step's vectors share;
  /// between the sizes measured without a gain (5 MiB) and with one (22 MiB). 0: always.
  std::size_t single_precision_min_bytes = std::size_t{16} << 20;
};

/// The options' names, ranges and documentation (core/option_fields.hpp); in the scene under
/// solver, prefixed compliance_. `precomputed` is not an option (the model folder's cache);
/// the precompute method and chunk are constants.
template <class V>
void visit_fields(ComplianceOptions& o, V&& v) {
  v("strategy", o.strategy, "dense compliance block, sparse solves, or auto (by the budget)");
  v("budget_mib", core::MebiBytes{o.memory_budget_bytes}, core::Range{0, 1 << 20},
    "memory for the dense compliance block (MiB)");
  v("precompute_threads", o.precompute_threads, core::Range{1, 256},
    "threads precomputing the block (the block is the same bit for bit)");
}

class ComplianceOperator {
 public:
  /// @param[in] factor CHOLMOD factor of K0_ff. Not owned; must outlive this object.
  /// @param[in] dofs   its DOF map. Not owned; must outlive this object.
  /// @param[in] block_nodes nodes any constraint can touch (for DENSE_BLOCK); may be empty.
  /// \throws brainshift::Error when DENSE_BLOCK is forced but the block exceeds the budget, or
  /// the factor is not usable.
  /// @param[in] fingerprint stiffness_fingerprint() of the model `factor` factorises; a
  /// precomputed block is adopted only when it carries the same one (0: never adopted).
  /// @param[in] factorised the free-DOF matrix K0_ff that `factor` factorises (read during
  /// construction only; may be null): with it the block is computed by the partial factorisation
  /// (options.precompute), without it by unit solves.
  ComplianceOperator(const core::CholmodFactor& factor, const core::DofMap& dofs,
                     std::vector<index_t> block_nodes, const ComplianceOptions& options = {},
                     std::uint64_t fingerprint = 0, const SparseMatrix* factorised = nullptr);

  /// The strategy in use (never AUTO).
  [[nodiscard]] ComplianceStrategy strategy() const { return m_strategy; }
  /// Bytes held by the dense block (0 for SPARSE_SOLVE).
  [[nodiscard]] std::size_t block_bytes() const;
  /// Bytes of Y in the last sparse-strategy call (0 if none).
  [[nodiscard]] std::size_t last_sparse_bytes() const { return m_last_sparse_bytes; }
  /// How many delassus() calls fell back from the block to sparse solves.
  [[nodiscard]] int fallback_count() const { return m_fallbacks; }
  [[nodiscard]] const std::vector<index_t>& block_nodes() const { return m_block_nodes; }
  /// tr (K0⁻¹)_nn, the trace of node n's 3×3 diagonal block (mm/mN), read from the dense block;
  /// −1 when n is not a block node or there is no block (SPARSE_SOLVE). The predicted error's
  /// prior term (registration/uncertainty.hpp) uses it instead of solving.
  [[nodiscard]] double block_trace(index_t node) const;
  /// The dense block with its fingerprint, for saving (matrix empty for SPARSE_SOLVE).
  [[nodiscard]] ComplianceBlock block() const {
    return {m_fingerprint, m_block_nodes, block_matrix()};
  }
  /// Where the block came from: "computed", "adopted" (from ComplianceOptions::precomputed),
  /// "rejected (<why>); computed", or "none (sparse_solve)".
  [[nodiscard]] const std::string& cache_status() const { return m_cache_status; }

  /// Sets the stored nodal rotations R (#N, proper) used by the overloads without a rotation
  /// argument. Empty = identity (unwarped K0⁻¹, the ablation). The registration never calls it:
  /// it passes the rotations per call, so a prepared model stays const (and shareable).
  void set_rotations(std::vector<Matrix3d> nodal_rotations);
  [[nodiscard]] const std::vector<Matrix3d>& rotations() const { return m_warp.rotations(); }

  /// R K0⁻¹ Rᵀ v (full 3N vectors; mN → mm), one solve with the factor, with the stored rotations.
  [[nodiscard]] Eigen::VectorXd apply(ConstRef<Eigen::VectorXd> v) const;
  /// Same with the nodal rotations `R` (#N, or empty for the identity) given per call, solved
  /// in single precision when the factor is large (ComplianceOptions::single_precision_solves,
  /// single_precision_min_bytes; single_precision() says which).
  [[nodiscard]] Eigen::VectorXd apply(ConstRef<Eigen::VectorXd> v,
                                      const std::vector<Matrix3d>& R) const;
  /// Whether apply(v, R) solves in single precision.
  [[nodiscard]] bool single_precision() const { return m_single != nullptr; }

  /// R K0⁻¹ Rᵀ V for the columns of V (3N × k; mN → mm) with one multi-right-hand-side solve:
  /// the factor is read once for all columns, so k = 2 costs little more than one apply().
  /// `R` as in apply(). Column j equals apply(V.col(j), R) to rounding.
  [[nodiscard]] Eigen::MatrixXd apply_columns(ConstRef<Eigen::MatrixXd> V,
                                              const std::vector<Matrix3d>& R) const;
  /// R K0⁻¹ Rᵀ v on the block nodes only, read from the dense block (no solve): a full 3N
  /// vector (mm), zero outside the block nodes. \pre DENSE_BLOCK, and v (mN) vanishes outside
  /// the block nodes (a force Hᵀλ of rows covers() accepts; forces on fixed nodes are ignored).
  /// There it equals apply(v, R) to rounding.
  [[nodiscard]] Eigen::VectorXd apply_block(ConstRef<Eigen::VectorXd> v,
                                            const std::vector<Matrix3d>& R) const;
  /// True when the dense block covers the rows of H: DENSE_BLOCK, and every node H touches is a
  /// block node or fixed (then delassus() and apply_block() need no solve).
  [[nodiscard]] bool covers(const SparseMatrix& H) const;

  /// W = H R K0⁻¹ Rᵀ Hᵀ (#rows², mm/mN) by the chosen strategy, with the stored rotations.
  /// H is #rows × 3N.
  [[nodiscard]] Eigen::MatrixXd delassus(const SparseMatrix& H) const;
  /// Same with the nodal rotations `R` given per call; `used_fallback` (optional) is set when
  /// the rows touched a node outside the block and sparse solves were used.
  [[nodiscard]] Eigen::MatrixXd delassus(const SparseMatrix& H, const std::vector<Matrix3d>& R,
                                         bool* used_fallback = nullptr) const;
  /// Strategy (a) explicitly. \pre every node H touches is a block node (else throws).
  [[nodiscard]] Eigen::MatrixXd delassus_dense_block(const SparseMatrix& H) const;
  [[nodiscard]] Eigen::MatrixXd delassus_dense_block(const SparseMatrix& H,
                                                     const std::vector<Matrix3d>& R) const;
  /// Strategy (b) explicitly.
  [[nodiscard]] Eigen::MatrixXd delassus_sparse(const SparseMatrix& H) const;
  [[nodiscard]] Eigen::MatrixXd delassus_sparse(const SparseMatrix& H,
                                                const std::vector<Matrix3d>& R) const;

 private:
  /// G = H R restricted to free DOFs, as a (#free × #rows) sparse matrix (= (H R)ᵀ restricted).
  [[nodiscard]] SparseMatrix rotated_transposed_free(const SparseMatrix& H,
                                                     const std::vector<Matrix3d>& R) const;
  /// Empty when `b` can be adopted as this model's block, else why not.
  [[nodiscard]] std::string check_precomputed(const ComplianceBlock& b,
                                              const std::vector<index_t>& free_of_block) const;

  const core::CholmodFactor* m_factor;  // not owned
  const core::DofMap* m_dofs;           // not owned
  core::WarpedCompliance m_warp;
  std::unique_ptr<const core::SingleFactor> m_single;  // apply(v, R)'s factor when not null
  ComplianceStrategy m_strategy = ComplianceStrategy::SPARSE_SOLVE;
  std::vector<index_t> m_block_nodes;
  std::vector<index_t> m_block_pos;  // node → position in the block, −1 outside
  Eigen::MatrixXd m_block;           // (3|S|)², column-major, zero on fixed DOFs (computed)
  std::shared_ptr<const ComplianceBlock> m_adopted;  // the cache's block when adopted
  /// The dense block: the adopted cache's matrix, else the computed one.
  [[nodiscard]] const Eigen::MatrixXd& block_matrix() const {
    return m_adopted ? m_adopted->matrix : m_block;
  }
  std::uint64_t m_fingerprint = 0;
  std::string m_cache_status = "none (sparse_solve)";
  // Statistics of the calls (the operator is used through const references during a
  // registration; the step also returns them per call in its result). Not synchronised.
  mutable std::size_t m_last_sparse_bytes = 0;
  mutable int m_fallbacks = 0;
};

/// Reference W = H K(R)⁻¹ Hᵀ with the exact rotated tangent K(R) = Σ R̂ₑ Kₑ R̂ₑᵀ refactorised
/// (tests and the benchmark only; not on the fast path). Returns an empty matrix if the
/// factorisation fails.
Eigen::MatrixXd exact_delassus(const core::CorotationalModel& model, const core::DofMap& dofs,
                               const std::vector<Matrix3d>& element_rotations,
                               const SparseMatrix& H);

}  // namespace brainshift::constraints
