#include "cmd_bench.hpp"

#include "apps/workflow/progress.hpp"

#include <CLI/CLI.hpp>

#include <iomanip>
#include <ostream>

namespace brainshift::apps {

CLI::App* add_bench_command(CLI::App& app, BenchArgs& args) {
  CLI::App* c = app.add_subcommand(
      "bench", "Speed against error on the phantom cases: sweeps, baselines, Pareto plot");
  c->add_flag("--quick", args.quick, "standard case and a few sweep points (< 2 min)");
  c->add_flag("--elastix", args.elastix,
              "also run elastix (Debian's, rigid + B-spline mutual information) on every case as "
              "the image-registration peer (about 30-60 s a case)");
  c->add_option("--suite", args.suite,
                "all, cases (every named case + baselines) or sweeps (on standard)")
      ->check(CLI::IsMember({"all", "cases", "sweeps"}))
      ->capture_default_str();
  c->add_option("--cases", args.cases, "named cases for the cases suite (default: all)")
      ->delimiter(',');
  c->add_option("--seed", args.seed, "phantom seed")->capture_default_str();
  c->add_option("--repeat", args.repeat, "registrations per run; times are of the median run")
      ->check(CLI::Range(1, 50))
      ->capture_default_str();
  c->add_flag("--keep-work", args.keep_work, "keep DIR/work (phantoms and models)");
  c->add_option("--refine", args.refine,
                "mesh refinement of the cases suite's models (as prepare --refine)")
      ->check(CLI::Range(0.5, 4.0))
      ->capture_default_str();
  c->add_option("--real-data", args.real_data,
                "real data folder: the icbm_* cases read DIR/icbm152/labels.nii.gz and are skipped "
                "when it is "
                "absent (default: $BRAINSHIFT_DATA, else ../shared/data)");
  c->add_option("--out", args.out,
                "output folder DIR (results.csv, results.json, results.md, pareto.png)")
      ->required();
  return c;
}

int run_bench(const BenchArgs& args, std::ostream& out) {
  const workflow::Progress progress("bench");
  const workflow::BenchResult result = workflow::run_benchmark(args, progress);
  const std::vector<workflow::BenchRow>& rows = result.rows;
  const nlohmann::json& meta = result.meta;
  int failed = 0;
  out << std::fixed << std::setprecision(2);
  out << "brainshift bench: " << rows.size() << " runs in " << progress.seconds() << " s\n";
  for (const workflow::BenchRow& r : rows) {
    if (!r.ok) ++failed;
    if (r.suite != "cases") continue;
    out << "  " << std::left << std::setw(30) << r.case_name << std::setw(24) << r.method
        << std::right;
    if (r.ok)
      out << " TRE " << r.tre_before_mean << " -> " << r.tre_mean << " mm (near " << r.tre_near_mean
          << ", far " << r.tre_far_mean << "), " << r.t.total << " s, " << r.stop << "\n";
    else
      out << " FAILED: " << r.error << "\n";
  }
  out << "  results: " << (args.out / "results.md").string() << ", results.csv, results.json"
      << (meta["plot"] == "pareto.png" ? ", pareto.png" : "") << "\n";
  if (meta["plot"] != "pareto.png")
    out << "  warning: no plot: " << meta["plot"].get<std::string>() << "\n";
  if (failed) out << "  " << failed << " run(s) failed; see results.md\n";
  return failed ? 2 : 0;
}

}  // namespace brainshift::apps
