#pragma once
/// @file
/// @brief The benchmark (`brainshift bench`): speed against error on the phantom cases.
/// Every run is a real registration on a phantom with known truth — generated, prepared and
/// registered through the same code as `phantom`, `prepare` and `register` — and records time per
/// stage, iterations, peak memory, TRE (mean, p95, max) and the shift corrected.
///
///   suite `cases`:  each named phantom case with the product's defaults (vessels only), and two
///                   baselines on the same data: `rigid_only` (the loop's rigid start alone) and
///                   `prescribed_displacement` (the seeds' forward model: each vessel point's
///                   nearest skeleton point is displaced onto it, no sliding, no re-pairing);
///   suite `sweeps`: on `standard`: mesh size (≈1k … 50k nodes), start (identity or rigid),
///                   intra-operative vessel sampling
///                   (1.25, 2.5, 5 mm), compliance strategy (dense block, sparse solves, unwarped
///                   K0 as the ablation), PGS tolerance (Gauss–Seidel forced), constraint sets
///                   (vessels; + footprint; + dura).
///
/// Writes DIR/results.csv, DIR/results.json (with the machine, build type, date and the fitted
/// growth exponents), DIR/results.md, DIR/pareto.png (gnuplot; its script and data are kept).
/// The phantoms and models are built under DIR/work and removed unless --keep-work.

#include "apps/bench/bench_run.hpp"
#include "apps/workflow/progress.hpp"

#include <nlohmann/json.hpp>

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace brainshift::workflow {

/// What to run (the flags of `brainshift bench`).
struct BenchOptions {
  bool quick = false;         ///< standard case and a few sweep points (CI smoke test, < 2 min)
  std::string suite = "all";  ///< all | cases | sweeps
  std::vector<std::string> cases;  ///< named cases for suite `cases` (default: every case)
  std::uint32_t seed = 1;          ///< phantom seed
  int repeat = 1;                  ///< registrations per run; the median run's times are recorded
  bool keep_work = false;          ///< keep DIR/work (phantoms and models)
  /// Mesh refinement of the cases suite's models (`prepare --refine`; 1: the default mesh). A
  /// stability check of the loop's choices against the mesh.
  double refine = 1.0;
  /// Real data (the icbm_* cases read DIR/icbm152/labels.nii.gz); absent: those cases are
  /// skipped with a message (results.json → skipped). Default: $BRAINSHIFT_DATA, else
  /// ../shared/data.
  std::filesystem::path real_data;
  /// The image-registration peer (baseline_elastix.hpp: Debian's elastix, run as a separate
  /// program; ≈ 30-60 s a case): rows elastix_rigid and elastix in the cases suite.
  bool elastix = false;
  std::filesystem::path out;  ///< DIR
};

/// The runs and what results.json says about them.
struct BenchResult {
  std::vector<BenchRow> rows;  ///< one per run (failed runs carry their error)
  nlohmann::json meta;         ///< results.json without `runs`: machine, seed, fits, plot, ...
};

/// Runs the benchmark and writes DIR (options.out) atomically; progress stages go to `progress`.
/// A run that fails or diverges is a row with its error (the others go on).
/// \throws brainshift::Error for bad options (an unknown case) or an unwritable DIR.
BenchResult run_benchmark(const BenchOptions& args, const Progress& progress);

}  // namespace brainshift::workflow
