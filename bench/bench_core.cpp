/// @file
/// @brief Micro-benchmarks of the mechanical core on hemisphere-sized ellipsoids of ~2k, ~20k and
/// ~100k nodes: K0 assembly, CHOLMOD analyse / factorise, one warped-compliance apply, element
/// rotations and one corotational internal-force evaluation. Meshes, matrices and factors are
/// built once per size in static fixtures (not timed). See docs/BENCHMARKS.md.

#include "bench_common.hpp"

#include "core/assembly/dof_map.hpp"
#include "core/assembly/stiffness_assembly.hpp"
#include "core/fem/corotational.hpp"
#include "core/solver/cholmod_factor.hpp"
#include "core/solver/nodal_rotations.hpp"
#include "core/solver/warped_compliance.hpp"

#include <benchmark/benchmark.h>

#include <map>
#include <memory>
#include <random>
#include <stdexcept>
#include <vector>

namespace brainshift::bench {
namespace {

constexpr double kMiB = 1024.0 * 1024.0;

/// Everything one mesh size needs, built once.
struct CoreScene {
  core::TetMesh mesh;
  std::unique_ptr<core::CorotationalModel> model;
  core::DofMap dofs;
  SparseMatrix K0;
  SparseMatrix Kff;
  core::CholmodFactor factor;        // analysed; factorised by the first user that needs it
  MatrixX3d x;                       // bent configuration (≤ 10°)
  core::ElementRotations rotations;  // at x
  std::vector<Matrix3d> nodal;       // at x
  Eigen::VectorXd load;              // a random full-size force vector (mN)
};

CoreScene& mutable_scene(int cells) {
  static std::map<int, std::unique_ptr<CoreScene>> cache;
  auto& slot = cache[cells];
  if (!slot) {
    auto s = std::make_unique<CoreScene>();
    s->mesh = hemisphere_mesh(cells);
    s->model = std::make_unique<core::CorotationalModel>(s->mesh);
    s->dofs = core::DofMap(s->mesh.num_nodes(), bottom_cap(s->mesh));
    s->K0 = core::assemble_rest_stiffness(*s->model);
    s->Kff = s->dofs.restrict(s->K0);
    s->factor.analyze(s->Kff);  // numeric factorisation: BM_CholmodFactorize, or factored()
    s->x = bent_configuration(s->mesh);
    s->rotations = s->model->element_rotations(s->x);
    s->nodal = core::nodal_rotations(s->mesh, s->rotations.rotation);
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    s->load = Eigen::VectorXd::NullaryExpr(s->dofs.num_full(), [&] { return u(rng); });
    slot = std::move(s);
  }
  return *slot;
}

const CoreScene& scene(int cells) { return mutable_scene(cells); }

/// The scene with its factor factorised (the 100k factorisation takes minutes: done once, by
/// BM_CholmodFactorize when it ran first).
const CoreScene& factored(int cells) {
  CoreScene& s = mutable_scene(cells);
  if (!s.factor.ok() && s.factor.factorize(s.Kff) != core::FactorStatus::OK)
    throw std::runtime_error("K0_ff not SPD: " + s.factor.message());
  return s;
}

void size_counters(benchmark::State& state, const CoreScene& s) {
  state.counters["nodes"] = static_cast<double>(s.mesh.num_nodes());
  state.counters["tets"] = static_cast<double>(s.mesh.num_tets());
  state.counters["free_dofs"] = static_cast<double>(s.dofs.num_free());
}

void factor_counters(benchmark::State& state, const core::CholmodFactor& f) {
  const auto nnz = static_cast<double>(f.factor_nonzeros());
  state.counters["nnz_L"] = nnz;
  state.counters["L_MiB"] = nnz * sizeof(double) / kMiB;  // numeric values of L only
}

void BM_AssembleK0(benchmark::State& state) {
  const CoreScene& s = scene(static_cast<int>(state.range(0)));
  for (auto _ : state) {
    SparseMatrix K = core::assemble_rest_stiffness(*s.model);
    benchmark::DoNotOptimize(K.valuePtr());
  }
  size_counters(state, s);
  state.counters["nnz_K0"] = static_cast<double>(s.K0.nonZeros());
  state.counters["K0_MiB"] =
      static_cast<double>(s.K0.nonZeros()) * (sizeof(double) + sizeof(index_t)) / kMiB;
}

void BM_RestrictK0ff(benchmark::State& state) {
  const CoreScene& s = scene(static_cast<int>(state.range(0)));
  for (auto _ : state) {
    SparseMatrix K = s.dofs.restrict(s.K0);
    benchmark::DoNotOptimize(K.valuePtr());
  }
  size_counters(state, s);
}

void BM_CholmodAnalyze(benchmark::State& state) {
  const CoreScene& s = scene(static_cast<int>(state.range(0)));
  for (auto _ : state) {
    core::CholmodFactor f;
    f.analyze(s.Kff);
    benchmark::DoNotOptimize(f);
  }
  size_counters(state, s);
  factor_counters(state, s.factor);  // the symbolic nnz(L) is known after analysis
}

void BM_CholmodFactorize(benchmark::State& state) {
  CoreScene& s = mutable_scene(static_cast<int>(state.range(0)));
  core::CholmodFactor& f = s.factor;  // analysed once in the fixture, as on the pre-operative path
  for (auto _ : state) {
    if (f.factorize(s.Kff) != core::FactorStatus::OK) {
      state.SkipWithError("factorisation failed");
      break;
    }
  }
  size_counters(state, s);
  factor_counters(state, f);
}

void BM_WarpedComplianceApply(benchmark::State& state) {
  const CoreScene& s = factored(static_cast<int>(state.range(0)));
  core::WarpedCompliance C(s.factor, s.dofs);
  C.set_rotations(s.nodal);
  for (auto _ : state) {
    Eigen::VectorXd u = C.apply(s.load);
    benchmark::DoNotOptimize(u.data());
  }
  size_counters(state, s);
  factor_counters(state, s.factor);
}

/// One solve K0_ff⁻¹ b in double (CHOLMOD) and with the single-precision copy of L; the
/// counter rel_error is ‖x_single − x‖ / ‖x‖ on the benchmark's load.
void BM_CholmodSolve(benchmark::State& state) {
  const CoreScene& s = factored(static_cast<int>(state.range(0)));
  const Eigen::VectorXd b = s.dofs.restrict(s.load);
  for (auto _ : state) {
    Eigen::VectorXd x = s.factor.solve(b);
    benchmark::DoNotOptimize(x.data());
  }
  size_counters(state, s);
  factor_counters(state, s.factor);
}

void BM_CholmodSolveSingle(benchmark::State& state) {
  const CoreScene& s = factored(static_cast<int>(state.range(0)));
  const core::SingleFactor single(s.factor);
  const Eigen::VectorXd b = s.dofs.restrict(s.load);
  for (auto _ : state) {
    Eigen::VectorXd x = single.solve(b);
    benchmark::DoNotOptimize(x.data());
  }
  const Eigen::VectorXd x = s.factor.solve(b);
  state.counters["rel_error"] = (single.solve(b) - x).norm() / x.norm();
  size_counters(state, s);
  factor_counters(state, s.factor);
}

void BM_ElementRotations(benchmark::State& state) {
  const CoreScene& s = scene(static_cast<int>(state.range(0)));
  for (auto _ : state) {
    core::ElementRotations r = s.model->element_rotations(s.x);
    benchmark::DoNotOptimize(r.rotation.data());
  }
  size_counters(state, s);
}

void BM_NodalRotations(benchmark::State& state) {
  const CoreScene& s = scene(static_cast<int>(state.range(0)));
  for (auto _ : state) {
    std::vector<Matrix3d> r = core::nodal_rotations(s.mesh, s.rotations.rotation);
    benchmark::DoNotOptimize(r.data());
  }
  size_counters(state, s);
}

/// One internal-force evaluation as the constrained step does it: element rotations (polar
/// decompositions) then f = Σ R̂ K_e (R̂ᵀ x_e − X_e).
void BM_InternalForce(benchmark::State& state) {
  const CoreScene& s = scene(static_cast<int>(state.range(0)));
  for (auto _ : state) {
    const core::ElementRotations r = s.model->element_rotations(s.x);
    Eigen::VectorXd f = s.model->internal_force(s.x, r.rotation);
    benchmark::DoNotOptimize(f.data());
  }
  size_counters(state, s);
}

/// Internal force only, rotations given.
void BM_InternalForceOnly(benchmark::State& state) {
  const CoreScene& s = scene(static_cast<int>(state.range(0)));
  for (auto _ : state) {
    Eigen::VectorXd f = s.model->internal_force(s.x, s.rotations.rotation);
    benchmark::DoNotOptimize(f.data());
  }
  size_counters(state, s);
}

// Ellipsoid cells per axis: 12 → 2,197 nodes, 26 → 19,683, 46 → 103,823.
void Sizes(benchmark::internal::Benchmark* b) {
  b->ArgName("cells")->Arg(12)->Arg(26)->Arg(46)->Unit(benchmark::kMillisecond);
}
void SmallSizes(benchmark::internal::Benchmark* b) {
  b->ArgName("cells")->Arg(12)->Arg(26)->Unit(benchmark::kMillisecond);
}
/// The ~100k-node mesh, where one run of assembly / analysis / factorisation takes seconds to
/// minutes: a single run (it overrides --benchmark_repetitions).
void LargeSizeOnce(benchmark::internal::Benchmark* b) {
  b->ArgName("cells")->Arg(46)->Unit(benchmark::kMillisecond)->Iterations(1)->Repetitions(1);
}

BENCHMARK(BM_AssembleK0)->Apply(SmallSizes);
BENCHMARK(BM_AssembleK0)->Apply(LargeSizeOnce);
BENCHMARK(BM_RestrictK0ff)->Apply(SmallSizes);
BENCHMARK(BM_RestrictK0ff)->Apply(LargeSizeOnce);
BENCHMARK(BM_CholmodAnalyze)->Apply(SmallSizes);
BENCHMARK(BM_CholmodAnalyze)->Apply(LargeSizeOnce);
BENCHMARK(BM_CholmodFactorize)->Apply(SmallSizes);
BENCHMARK(BM_CholmodFactorize)->Apply(LargeSizeOnce);
BENCHMARK(BM_WarpedComplianceApply)->Apply(Sizes);
BENCHMARK(BM_CholmodSolve)->Apply(SmallSizes);
BENCHMARK(BM_CholmodSolveSingle)->Apply(SmallSizes);
BENCHMARK(BM_ElementRotations)->Apply(Sizes);
BENCHMARK(BM_NodalRotations)->Apply(Sizes);
BENCHMARK(BM_InternalForce)->Apply(Sizes);
BENCHMARK(BM_InternalForceOnly)->Apply(Sizes);

}  // namespace
}  // namespace brainshift::bench

BENCHMARK_MAIN();
