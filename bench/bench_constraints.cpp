/// @file
/// @brief Micro-benchmarks of the constraint path on hemisphere-sized ellipsoids (~2k and ~20k
/// nodes) with 100 … 3,000 realistic rows, and of the registration's global start (500 points,
/// 1.7k nodes; against the rigid ICP + shift search it replaced): the Delassus operator W = H R
/// K0⁻¹ Rᵀ Hᵀ by both strategies (dense block: precompute and per-call product reported separately;
/// sparse solves), projected Gauss–Seidel, and one full constrained step. Scenes are built once per
/// (mesh, rows) in static fixtures (not timed). See docs/BENCHMARKS.md.
///
/// Rows: mapped points (random barycentric weights in tetrahedra whose four nodes lie near the
/// surface, scaled radius > 0.8, away from the fixed cap), alternately a sliding line (2 rows,
/// random tangent, target up to 2 mm off the line) and a unilateral plane (1 row, inward normal,
/// signed violation uniform in ±2 mm), built at a configuration bent by up to 10°, so the
/// compliance is warped by realistic nodal rotations.

#include "bench_common.hpp"

#include "constraints/registration/registration.hpp"
#include "constraints/registration/start/bulk_search.hpp"
#include "constraints/registration/start/global_start.hpp"
#include "constraints/rows/constraint_rows.hpp"
#include "constraints/solver/compliance_operator.hpp"
#include "constraints/solver/constrained_step.hpp"
#include "constraints/solver/pgs.hpp"
#include "core/solver/nodal_rotations.hpp"

#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdlib>
#include <map>
#include <memory>
#include <numbers>
#include <random>
#include <stdexcept>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

namespace brainshift::bench {
namespace {

using constraints::ComplianceOperator;
using constraints::ComplianceOptions;
using constraints::ComplianceStrategy;
using constraints::ConstrainedModel;
using constraints::ConstraintRows;
using constraints::ConstraintSet;
using constraints::Stencil;

constexpr double kMiB = 1024.0 * 1024.0;
const std::size_t kBudget = ComplianceOptions{}.memory_budget_bytes;  // 512 MiB default

/// Mesh, fixed cap, bent configuration; the sparse-strategy model (factor of K0_ff) shared by
/// the W benchmarks of every row count.
struct MeshScene {
  core::TetMesh mesh;
  std::vector<index_t> fixed;
  MatrixX3d x;
  std::unique_ptr<ConstrainedModel> model;     // no block nodes → sparse strategy (stepping swaps
                                               // in the dense block of the row set, see BM_Step)
  std::unique_ptr<ComplianceOperator> sparse;  // sparse strategy, for BM_W_Sparse
  std::vector<Matrix3d> nodal;                 // nodal rotations at x
  Eigen::VectorXd dx_free;                     // free motion C (−f_int(x)) at x
  std::vector<index_t> candidate_tets;         // tets with all nodes near the surface
};

MeshScene& mesh_scene(int cells) {
  static std::map<int, std::unique_ptr<MeshScene>> cache;
  auto& slot = cache[cells];
  if (!slot) {
    auto s = std::make_unique<MeshScene>();
    s->mesh = hemisphere_mesh(cells);
    s->fixed = bottom_cap(s->mesh);
    s->x = bent_configuration(s->mesh);
    ComplianceOptions sparse;
    sparse.strategy = ComplianceStrategy::SPARSE_SOLVE;
    s->model =
        std::make_unique<ConstrainedModel>(s->mesh, s->fixed, std::vector<index_t>{}, sparse);
    const core::ElementRotations er = s->model->model().element_rotations(s->x);
    s->nodal = core::nodal_rotations(s->mesh, er.rotation);
    s->model->compliance().set_rotations(s->nodal);
    s->sparse = std::make_unique<ComplianceOperator>(s->model->factor(), s->model->dofs(),
                                                     std::vector<index_t>{}, sparse);
    s->sparse->set_rotations(s->nodal);
    s->dx_free = s->model->compliance().apply(-s->model->model().internal_force(s->x, er.rotation));
    const auto& X = s->mesh.nodes();
    const auto& T = s->mesh.tets();
    for (index_t t = 0; t < s->mesh.num_tets(); ++t) {
      bool ok = true;
      for (int k = 0; k < 4 && ok; ++k) {
        const Vector3d p = X.row(T(t, k)).transpose();
        ok = scaled_radius(p) > 0.8 && p.z() > -40.0;
      }
      if (ok) s->candidate_tets.push_back(t);
    }
    slot = std::move(s);
  }
  return *slot;
}

/// Rows and everything built from them for one (mesh, row count).
struct RowScene {
  ConstraintRows rows;
  SparseMatrix H;
  std::vector<index_t> block_nodes;  // nodes the rows touch
  std::size_t block_bytes = 0;       // 8 (3|S|)²
  bool block_fits = false;
  std::unique_ptr<ComplianceOperator> dense;  // the precomputed block (when it fits the budget)
  Eigen::MatrixXd W;                          // for the PGS benchmark (built on first use)
  Eigen::VectorXd delta_free;
};

/// The 20k-node mesh with 3,000 rows: the block is over budget, so W needs sparse solves that
/// take minutes per call (see docs/BENCHMARKS.md); run only when BS_BENCH_FULL=1.
bool too_slow_by_default(int cells, int count) {
  const char* full = std::getenv("BS_BENCH_FULL");
  return cells >= 26 && count >= 3000 && !(full != nullptr && std::string(full) == "1");
}

/// Smooth displacement field (mm, |d| ≲ 2 mm): a coherent shift, for the `smooth` variant.
Vector3d smooth_shift(const Vector3d& p) {
  return Vector3d(1.2 * std::sin(p.y() / 35.0), 0.8 * std::cos(p.x() / 40.0),
                  -1.0 - 0.5 * std::sin(p.z() / 30.0));
}

/// `smooth`: targets from a smooth field instead of independent random offsets.
ConstraintRows make_rows(const MeshScene& s, int count, bool smooth) {
  std::mt19937 rng(2024);  // same seed for every count: smaller row sets are prefixes
  std::uniform_int_distribution<std::size_t> pick(0, s.candidate_tets.size() - 1);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  std::normal_distribution<double> gauss(0.0, 1.0);
  auto random_unit = [&] {
    Vector3d v(gauss(rng), gauss(rng), gauss(rng));
    return Vector3d(v.normalized());
  };
  const auto& T = s.mesh.tets();
  const Vector3d& axes = hemisphere_semi_axes();
  ConstraintRows rows;
  for (int k = 0; rows.size() < count; ++k) {
    const index_t t = s.candidate_tets[pick(rng)];
    Vector4d w(u01(rng), u01(rng), u01(rng), u01(rng));
    w /= w.sum();
    Stencil st;
    for (int j = 0; j < 4; ++j) st.add(T(t, j), w[j]);
    const Vector3d p = st.position(s.x);
    if (k % 2 == 0 && count - rows.size() >= 2) {
      // Vessel centreline: p should lie on a line up to 2 mm away, free along it.
      const Vector3d tangent = random_unit();
      Vector3d off = random_unit();
      off = (off - off.dot(tangent) * tangent).normalized() * 2.0 * u01(rng);
      if (smooth) off = smooth_shift(p);
      rows.add_sliding_line(st, s.x, p + off, tangent, ConstraintSet::VESSELS, k);
    } else {
      // Dura / footprint contact: stay inside, n · (p − target) ≥ 0 with n the inward normal.
      const Vector3d n = -p.cwiseQuotient(axes.cwiseProduct(axes)).normalized();
      double violation = 4.0 * u01(rng) - 2.0;  // ±2 mm, negative = violated
      if (smooth) violation = -n.dot(smooth_shift(p));
      rows.add_unilateral_plane(st, s.x, p - violation * n, n, ConstraintSet::DURA, k);
    }
  }
  return rows;
}

RowScene& row_scene(int cells, int count, bool smooth = false) {
  static std::map<std::tuple<int, int, bool>, std::unique_ptr<RowScene>> cache;
  auto& slot = cache[{cells, count, smooth}];
  if (!slot) {
    const MeshScene& s = mesh_scene(cells);
    auto r = std::make_unique<RowScene>();
    r->rows = make_rows(s, count, smooth);
    r->H = r->rows.jacobian(s.mesh.num_nodes());
    std::vector<char> touched(static_cast<std::size_t>(s.mesh.num_nodes()), 0);
    for (const auto& row : r->rows.rows())
      for (int k = 0; k < row.stencil.size; ++k) touched[row.stencil.node[k]] = 1;
    for (index_t n = 0; n < s.mesh.num_nodes(); ++n)
      if (touched[n]) r->block_nodes.push_back(n);
    const std::size_t nb = 3 * r->block_nodes.size();
    r->block_bytes = nb * nb * sizeof(double);
    r->block_fits = r->block_bytes <= kBudget;
    r->delta_free = r->rows.violations() + r->H * s.dx_free;
    slot = std::move(r);
  }
  return *slot;
}

ComplianceOperator make_dense(const MeshScene& s, const RowScene& r) {
  ComplianceOptions dense;
  dense.strategy = ComplianceStrategy::DENSE_BLOCK;
  return ComplianceOperator(s.model->factor(), s.model->dofs(), r.block_nodes, dense);
}

/// The dense operator of a row set, precomputed on first use (untimed) unless
/// BM_W_DenseBlockPrecompute already built it. Null when the block is over the budget.
ComplianceOperator* dense_operator(const MeshScene& s, RowScene& r) {
  if (!r.block_fits) return nullptr;
  if (!r.dense) r.dense = std::make_unique<ComplianceOperator>(make_dense(s, r));
  r.dense->set_rotations(s.nodal);
  return r.dense.get();
}

/// W of a row set (AUTO: dense block when it fits), for PGS.
const Eigen::MatrixXd& delassus(const MeshScene& s, RowScene& r) {
  if (r.W.size() == 0) {
    ComplianceOperator* d = dense_operator(s, r);
    r.W = d != nullptr ? d->delassus_dense_block(r.H) : s.sparse->delassus_sparse(r.H);
  }
  return r.W;
}

std::string over_budget(const RowScene& r) {
  return "dense block over the 512 MiB budget (" + std::to_string(r.block_bytes >> 20) + " MiB)";
}

void row_counters(benchmark::State& state, const MeshScene& s, const RowScene& r) {
  state.counters["nodes"] = static_cast<double>(s.mesh.num_nodes());
  state.counters["rows"] = static_cast<double>(r.rows.size());
  state.counters["block_nodes"] = static_cast<double>(r.block_nodes.size());
  state.counters["block_MiB"] = static_cast<double>(r.block_bytes) / kMiB;
}

// --- W, dense block ----------------------------------------------------------------------------

/// Pre-operative precompute of the dense block C = K0_ff⁻¹ on the block DOFs (3|S| solves).
void BM_W_DenseBlockPrecompute(benchmark::State& state) {
  const int cells = static_cast<int>(state.range(0));
  const MeshScene& s = mesh_scene(cells);
  RowScene& r = row_scene(cells, static_cast<int>(state.range(1)));
  row_counters(state, s, r);
  if (!r.block_fits) {
    state.SkipWithError(over_budget(r).c_str());
    return;
  }
  for (auto _ : state) {
    ComplianceOperator op = make_dense(s, r);
    benchmark::DoNotOptimize(op.block_bytes());
    state.PauseTiming();
    r.dense = std::make_unique<ComplianceOperator>(std::move(op));  // kept for the W benchmarks
    state.ResumeTiming();
  }
}

/// Per-iteration W = G C Gᵀ from the precomputed block.
void BM_W_DenseBlock(benchmark::State& state) {
  const int cells = static_cast<int>(state.range(0));
  const MeshScene& s = mesh_scene(cells);
  RowScene& r = row_scene(cells, static_cast<int>(state.range(1)));
  row_counters(state, s, r);
  ComplianceOperator* dense = dense_operator(s, r);
  if (dense == nullptr) {
    state.SkipWithError(over_budget(r).c_str());
    return;
  }
  const ComplianceOperator& op = *dense;
  for (auto _ : state) {
    Eigen::MatrixXd W = op.delassus_dense_block(r.H);
    benchmark::DoNotOptimize(W.data());
  }
  state.counters["held_MiB"] = static_cast<double>(op.block_bytes()) / kMiB;
}

// --- W, sparse solves --------------------------------------------------------------------------

/// Per-iteration Y = L⁻¹ P (H R)ᵀ (CHOLMOD sparse solve), W = Yᵀ Y.
void BM_W_Sparse(benchmark::State& state) {
  const int cells = static_cast<int>(state.range(0));
  const MeshScene& s = mesh_scene(cells);
  const int count = static_cast<int>(state.range(1));
  const RowScene& r = row_scene(cells, count);
  row_counters(state, s, r);
  if (too_slow_by_default(cells, count)) {
    state.SkipWithError("skipped: minutes per call; set BS_BENCH_FULL=1");
    return;
  }
  ComplianceOperator& op = *s.sparse;
  for (auto _ : state) {
    Eigen::MatrixXd W = op.delassus_sparse(r.H);
    benchmark::DoNotOptimize(W.data());
  }
  state.counters["Y_MiB"] = static_cast<double>(op.last_sparse_bytes()) / kMiB;
  state.counters["W_MiB"] =
      static_cast<double>(r.rows.size()) * r.rows.size() * sizeof(double) / kMiB;
}

// --- PGS ---------------------------------------------------------------------------------------

void BM_PGS(benchmark::State& state) {
  const int cells = static_cast<int>(state.range(0));
  const MeshScene& s = mesh_scene(cells);
  const int count = static_cast<int>(state.range(1));
  RowScene& r = row_scene(cells, count);
  row_counters(state, s, r);
  if (too_slow_by_default(cells, count)) {
    state.SkipWithError("skipped: W needs minutes of sparse solves; set BS_BENCH_FULL=1");
    return;
  }
  const Eigen::MatrixXd& W = delassus(s, r);
  constraints::PgsResult res;
  for (auto _ : state) {
    res = constraints::solve_pgs(W, r.delta_free, r.rows, Eigen::VectorXd());
    benchmark::DoNotOptimize(res.lambda.data());
  }
  state.counters["sweeps"] = res.iterations;
  state.counters["converged"] = res.stop == constraints::PgsStop::CONVERGED ? 1 : 0;
  state.counters["residual"] = res.residual;
}

// --- One constrained step ----------------------------------------------------------------------

/// ConstrainedModel::step: element rotations, internal force, nodal rotations, free motion, H,
/// W (AUTO strategy: the dense block when it fits the budget, else sparse solves), PGS,
/// correction. The mesh's model is shared by all row sets; the row set's precomputed block is
/// swapped in as the model's compliance operator for the run (what AUTO would have built).
void run_step(benchmark::State& state, int cells, int count, bool smooth) {
  MeshScene& s = mesh_scene(cells);
  RowScene& r = row_scene(cells, count, smooth);
  row_counters(state, s, r);
  if (too_slow_by_default(cells, count)) {
    state.SkipWithError("skipped: sparse W takes minutes per call; set BS_BENCH_FULL=1");
    return;
  }
  ComplianceOperator* dense = dense_operator(s, r);
  if (dense != nullptr) std::swap(s.model->compliance(), *dense);
  const constraints::StepOptions options;
  constraints::StepResult res;
  double free = 0, delassus_s = 0, pgs = 0, corr = 0;
  for (auto _ : state) {
    res = s.model->step(s.x, r.rows, options);
    benchmark::DoNotOptimize(res.x.data());
    free += res.seconds_free_motion;
    delassus_s += res.seconds_delassus;
    pgs += res.seconds_pgs;
    corr += res.seconds_correction;
  }
  state.counters["dense"] =
      s.model->compliance().strategy() == ComplianceStrategy::DENSE_BLOCK ? 1 : 0;
  state.counters["fallbacks"] = s.model->compliance().fallback_count();
  if (dense != nullptr) std::swap(s.model->compliance(), *dense);
  const double n = static_cast<double>(state.iterations());
  state.counters["free_ms"] = 1e3 * free / n;
  state.counters["W_ms"] = 1e3 * delassus_s / n;
  state.counters["pgs_ms"] = 1e3 * pgs / n;
  state.counters["corr_ms"] = 1e3 * corr / n;
  state.counters["sweeps"] = res.pgs.iterations;
  state.counters["converged"] = res.pgs.stop == constraints::PgsStop::CONVERGED ? 1 : 0;
}

void BM_Step(benchmark::State& state) {
  run_step(state, static_cast<int>(state.range(0)), static_cast<int>(state.range(1)), false);
}

/// Same, with targets from a smooth ±2 mm displacement field (a coherent brain shift) instead
/// of independent random offsets: consistent rows, the PGS converges.
void BM_StepSmooth(benchmark::State& state) {
  run_step(state, static_cast<int>(state.range(0)), static_cast<int>(state.range(1)), true);
}

/// CHOLMOD part of the sparse strategy alone: Y = L⁻¹ P G for G = Hᵀ on the free DOFs (the
/// pattern of (H R)ᵀ), without forming W = Yᵀ Y.
void BM_W_SparseLowerSolveOnly(benchmark::State& state) {
  const int cells = static_cast<int>(state.range(0));
  const MeshScene& s = mesh_scene(cells);
  const RowScene& r = row_scene(cells, static_cast<int>(state.range(1)));
  row_counters(state, s, r);
  const core::DofMap& dofs = s.model->dofs();
  std::vector<Triplet> trip;
  const SparseMatrix Ht = r.H.transpose();
  for (int j = 0; j < Ht.outerSize(); ++j)
    for (SparseMatrix::InnerIterator it(Ht, j); it; ++it)
      if (dofs.free_index(it.row()) >= 0)
        trip.emplace_back(dofs.free_index(it.row()), j, it.value());
  SparseMatrix G(dofs.num_free(), r.H.rows());
  G.setFromTriplets(trip.begin(), trip.end());
  SparseMatrix Y;
  for (auto _ : state) {
    Y = s.model->factor().solve_lower_permuted(G);
    benchmark::DoNotOptimize(Y.valuePtr());
  }
  state.counters["Y_nnz_per_col"] =
      static_cast<double>(Y.nonZeros()) / static_cast<double>(Y.cols());
  state.counters["Y_density"] = static_cast<double>(Y.nonZeros()) /
                                (static_cast<double>(Y.cols()) * static_cast<double>(Y.rows()));
}

// --- The global start (issue 14 item 2): 500 vessel points, ~1.7k nodes ----------------------

/// A model of the 11-cell ellipsoid (1,728 nodes) with 16 wavy vessels (30 mm each, 1 mm
/// segments) in the cortex-like top region, its load responses computed once (model-only work),
/// and 500 noisy vessel points seen through a 20 mm / 4° tracking offset.
struct StartScene {
  std::unique_ptr<constraints::RegistrationModel> model;
  MatrixX3d points;  // intra-operative frame
};

StartScene& start_scene() {
  static std::unique_ptr<StartScene> scene;
  if (!scene) {
    scene = std::make_unique<StartScene>();
    const core::TetMesh mesh = hemisphere_mesh(11);
    core::Skeleton skel;
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    std::vector<Vector3d> pts;
    for (int v = 0; v < 16; ++v) {
      Vector3d p(-20 + 40 * u(rng), -20 + 40 * u(rng), 12 + 18 * u(rng));
      const double a = 2 * std::numbers::pi * u(rng), wave = 8 + 8 * u(rng);
      const Vector3d d(std::cos(a), std::sin(a), 0.2 * (u(rng) - 0.5));
      for (int k = 0; k <= 30; ++k) {
        Vector3d q = p + k * d.normalized() +
                     1.2 * std::sin(2 * std::numbers::pi * k / wave) *
                         Vector3d(-d.y(), d.x(), 0).normalized();
        q = q.cwiseMax(Vector3d(-25, -25, 10))
                .cwiseMin(Vector3d(25, 25, 32));  // stay inside the ellipsoid
        pts.push_back(q);
        if (k > 0)
          skel.segments.push_back(
              {static_cast<index_t>(pts.size()) - 2, static_cast<index_t>(pts.size()) - 1});
      }
    }
    skel.points.resize(static_cast<Eigen::Index>(pts.size()), 3);
    for (std::size_t i = 0; i < pts.size(); ++i)
      skel.points.row(static_cast<Eigen::Index>(i)) = pts[i].transpose();
    // 500 points along the vessels (uniform on the segments) with 0.3 mm noise, then the offset.
    std::normal_distribution<double> noise(0.0, 0.3);
    Eigen::Isometry3d O = Eigen::Isometry3d::Identity();
    O.rotate(Eigen::AngleAxisd(4.0 * std::numbers::pi / 180, Vector3d(1, -2, 0.5).normalized()));
    O.pretranslate(20.0 * Vector3d(0.5, 0.8, -0.33).normalized());
    scene->points.resize(500, 3);
    for (Eigen::Index i = 0; i < 500; ++i) {
      const auto& e = skel.segments[static_cast<std::size_t>(
                                        u(rng) * static_cast<double>(skel.segments.size())) %
                                    skel.segments.size()];
      const Vector3d x = skel.points.row(e[0]).transpose() +
                         u(rng) * (skel.points.row(e[1]) - skel.points.row(e[0])).transpose();
      scene->points.row(i) = (O * (x + Vector3d(noise(rng), noise(rng), noise(rng)))).transpose();
    }
    scene->model = std::make_unique<constraints::RegistrationModel>(
        mesh, bottom_cap(mesh), std::move(skel), core::SurfaceMesh{});
    (void)scene->model->load_response();
  }
  return *scene;
}

/// The global start with the bulk response (what register_model runs with start = RIGID).
void BM_GlobalStart(benchmark::State& state) {
  StartScene& s = start_scene();
  constraints::RegistrationModel& m = *s.model;
  const constraints::BasisAt basis = [&m](ConstRef<MatrixX3d> x) {
    return constraints::load_basis(m.mesh(), m.load_response(), x);
  };
  constraints::StartResult r;
  for (auto _ : state)
    benchmark::DoNotOptimize(r = constraints::global_start(m.skeleton(), s.points, basis, {}));
  state.counters["accepted"] = r.accepted;
  state.counters["table_ms"] = 1e3 * r.seconds_table;
  state.counters["coarse_ms"] = 1e3 * r.seconds_coarse;
  state.counters["fine_ms"] = 1e3 * r.seconds_fine;
  state.counters["refine_ms"] = 1e3 * r.seconds_refine;
  state.counters["nodes"] = static_cast<double>(m.mesh().num_nodes());
}

// Meshes: 12 cells → 2,197 nodes, 26 → 19,683. Rows: 100, 300, 1,000, 3,000, plus 600 on the
// 2k mesh (seed-002 scale, the 10 ms target).
void SmallMesh(benchmark::internal::Benchmark* b) {
  b->ArgNames({"cells", "rows"})->Unit(benchmark::kMillisecond);
  for (int rows : {100, 300, 600, 1000, 3000}) b->Args({12, rows});
}
void LargeMesh(benchmark::internal::Benchmark* b) {
  b->ArgNames({"cells", "rows"})->Unit(benchmark::kMillisecond);
  for (int rows : {100, 300, 1000, 3000}) b->Args({26, rows});
}

// Precompute: one timed run per repetition (seconds each); on the 20k mesh, a single run
// (it overrides --benchmark_repetitions: 13 s … 2 min per run).
BENCHMARK(BM_W_DenseBlockPrecompute)->Apply(SmallMesh)->Iterations(1);
BENCHMARK(BM_W_DenseBlockPrecompute)->Apply(LargeMesh)->Iterations(1)->Repetitions(1);
BENCHMARK(BM_W_DenseBlock)->Apply(SmallMesh)->Apply(LargeMesh);
BENCHMARK(BM_W_Sparse)->Apply(SmallMesh);
BENCHMARK(BM_W_Sparse)->Apply(LargeMesh)->Iterations(1)->Repetitions(1);
BENCHMARK(BM_W_SparseLowerSolveOnly)->Apply(SmallMesh);
BENCHMARK(BM_PGS)->Apply(SmallMesh)->Apply(LargeMesh);
BENCHMARK(BM_Step)->Apply(SmallMesh)->Apply(LargeMesh);
BENCHMARK(BM_GlobalStart)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_StepSmooth)
    ->ArgNames({"cells", "rows"})
    ->Args({12, 600})
    ->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace brainshift::bench

BENCHMARK_MAIN();
