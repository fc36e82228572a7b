#include "apps/bench/bench.hpp"

#include "apps/bench/baseline_elastix.hpp"
#include "apps/bench/baselines.hpp"
#include "apps/bench/bench_table.hpp"
#include "apps/workflow/intraop_footprint.hpp"
#include "apps/workflow/model_folder.hpp"
#include "core/error.hpp"
#include "data_synth/cases/case_catalog.hpp"

#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <map>
#include <optional>
#include <sstream>

namespace brainshift::workflow {

using constraints::RegistrationOptions;
using constraints::RegistrationResult;

BenchResult run_benchmark(const BenchOptions& args, const Progress& progress) {
  verify_output_folder(args.out);
  BS_VERIFY(!args.elastix || elastix_available(),
            "bench --elastix: elastix and transformix are not on the PATH (Debian package "
            "'elastix'; scripts/install_deps.sh installs it)");
  std::vector<std::string> cases = args.cases;
  std::vector<std::string> known = data_synth::case_names();
  known.insert(known.end(), real_anatomy_cases().begin(), real_anatomy_cases().end());
  for (const auto& c : cases)
    BS_VERIFY(std::find(known.begin(), known.end(), c) != known.end(),
              "bench: unknown case '" << c << "'");
  if (cases.empty()) cases = args.quick ? std::vector<std::string>{"standard"} : known;
  std::filesystem::path real_data = args.real_data;
  if (real_data.empty()) {
    const char* env = std::getenv("BRAINSHIFT_DATA");
    real_data = env && *env ? std::filesystem::path(env) : std::filesystem::path("../shared/data");
  }
  std::vector<std::string> skipped;
  if (!std::filesystem::is_regular_file(icbm_labels(real_data))) {
    for (const auto& c : cases)
      if (is_real_anatomy_case(c)) {
        skipped.push_back(c);
        std::cerr << "brainshift bench: skipping " << c << ": " << icbm_labels(real_data).string()
                  << " is absent (--real-data DIR)\n";
      }
    std::erase_if(cases, is_real_anatomy_case);
  }
  const bool do_cases = args.suite != "sweeps", do_sweeps = args.suite != "cases";

  BenchResult result;
  std::vector<BenchRow>& rows = result.rows;
  nlohmann::json& meta = result.meta;
  meta = {{"machine", machine()},
          {"seed", args.seed},
          {"refine", args.refine},
          {"quick", args.quick},
          {"repeat", args.repeat},
          {"suite", args.suite},
          {"skipped", skipped},
          {"note",
           "times are wall seconds of this process (2 threads at most); peak_rss_mib is the "
           "process's high-water mark during the run (kernel VmHWM, reset before each run)"}};
  write_folder_atomically(args.out, [&](const std::filesystem::path& dir) {
    const auto work = dir / "work";
    std::filesystem::create_directories(work);
    std::map<std::string, CaseData> made;
    auto case_data = [&](const std::string& name) -> const CaseData& {
      if (!made.count(name)) {
        progress.stage("phantom '" + name + "' (seed " + std::to_string(args.seed) + ")");
        made.emplace(name, make_case(name, args.seed, work / name / "phantom", real_data));
      }
      return made.at(name);
    };
    auto base_row = [&](const std::string& suite, const std::string& name) {
      BenchRow r;
      r.suite = suite;
      r.case_name = name;
      r.seed = args.seed;
      r.method = "constraint_icp";
      return r;
    };

    // Suite `cases`: each case with the defaults, and the two baselines.
    std::optional<double> standard_prepare_s;
    if (do_cases)
      for (const std::string& name : cases) {
        BenchRow failed = base_row("cases", name);
        try {
          const CaseData& c = case_data(name);
          const auto model_dir = work / name / "model";
          progress.stage(name + ": prepare");
          const double prepare_s = prepare_case(c, model_dir, args.refine);
          if (name == "standard") standard_prepare_s = prepare_s;
          Session s = open_session(model_dir);
          constraints::IntraopData data;
          data.vessel_points = doppler_points(s, c, 2.5);
          const RegistrationOptions o = product_options(s);
          // Variants of our loop. In every run: old_loop — the loop before 2026-12-03 (the vessel
          // ratio fixed at 0.2, no noise model, the start's bulk shift unbounded);
          // bulk_start_only — the global start's rigid + bulk state, no loop. Full runs only:
          // fixed_compliance — the default without the noise model (the ratio fixed at 0.2);
          // unbounded_start — the default with the start's bulk shift free to point out of the
          // brain (GlobalStartOptions::bulk_sinks off);
          // block_cv — the vessel compliance chosen by leave-one-branch-out cross-validation at
          // its minimum, from a rigid-only global start (ε → ∞ the rigid answer);
          // block_cv_1se / block_cv_paired — the same with the one-standard-error rule, and with
          // the paired test at z = 1 against ε → ∞;
          // block_cv_1se_bulk — the one-SE rule from the start's rigid + bulk state;
          // gcv_compliance — the SMOOTH stage at the compliance chosen by generalised
          // cross-validation; dura_sliding / dura_unilateral — dura contact
          // outside the craniotomy on (the default is none): what the boundary conditions do off
          // the vessels (far-landmark TRE).
          std::map<std::string, RegistrationOptions> variants;
          variants["constraint_icp"] = o;
          variants["old_loop"] = o;
          variants["old_loop"].noise.enabled = false;
          variants["old_loop"].global_start.bulk_sinks = false;
          // navigation_prior — the pose under the prior of RESECT's real navigation offsets
          // (GlobalStartOptions::navigation_accuracy_mm = 6.6 mm RMS): the sag, not the pose,
          // explains what the two explain alike.
          variants["navigation_prior"] = o;
          variants["navigation_prior"].global_start.navigation_accuracy_mm =
              constraints::kResectNavigationAccuracyMm;
          std::vector<std::string> methods = {"constraint_icp", "old_loop", "navigation_prior"};
          if (!args.quick) {
            variants["fixed_compliance"] = o;
            variants["fixed_compliance"].noise.enabled = false;
            variants["unbounded_start"] = o;
            variants["unbounded_start"].global_start.bulk_sinks = false;
            RegistrationOptions cv = o;  // the SMOOTH stage from a rigid-only start
            cv.global_start.bulk_response = false;
            cv.noise.start_is_bulk_state = false;
            cv.noise.paired_test = false;
            cv.noise.paired_test_z = 1.0;
            variants["block_cv"] = cv;
            variants["block_cv_1se"] = cv;
            variants["block_cv_1se"].noise.one_standard_error = true;
            variants["block_cv_paired"] = cv;
            variants["block_cv_paired"].noise.paired_test = true;
            variants["block_cv_1se_bulk"] = o;
            variants["block_cv_1se_bulk"].noise.paired_test = false;
            variants["block_cv_1se_bulk"].noise.one_standard_error = true;
            variants["gcv_compliance"] = cv;
            variants["gcv_compliance"].noise.criterion = constraints::NoiseCriterion::GCV;
            variants["dura_sliding"] = o;
            variants["dura_sliding"].dura.mode = constraints::DuraOptions::Mode::SLIDING;
            variants["dura_unilateral"] = o;
            variants["dura_unilateral"].dura.mode = constraints::DuraOptions::Mode::UNILATERAL;
            // identity_start — no pose search (the navigation taken as right; the true pose of
            // the cases without an offset): what the deformation alone does with the sag.
            variants["identity_start"] = o;
            variants["identity_start"].start = constraints::RigidStart::IDENTITY;
            methods.insert(methods.end(),
                           {"fixed_compliance", "unbounded_start", "block_cv", "block_cv_1se",
                            "block_cv_1se_bulk", "block_cv_paired", "gcv_compliance",
                            "dura_sliding", "dura_unilateral", "identity_start"});
          }
          methods.push_back("bulk_start_only");
          // pre_dura — the pose measured on the sweep made before the dura was opened
          // (`register --pre-dura`), the loop otherwise the default; in --quick runs too.
          constraints::IntraopData data_pre = data;
          if (const auto pre = c.phantom / "intraop/predura/doppler.nii.gz";
              std::filesystem::exists(pre)) {
            nlohmann::json ignored;
            data_pre.pose = pose_from_pre_dura(s, pre, o, ignored);
            variants["pre_dura"] = o;
            // pre_dura_z1, pre_dura_z2 — the same with the paired test at one and two standard
            // errors (the former defaults with a pose: NoiseOptions::paired_test_z_with_pose);
            // pre_dura_start_only — the pre-dura pose and the bulk search alone, no loop: the
            // "rigid alone" of the two-sweep workflow; pre_dura_from_rest — the loop started at
            // the rest nodes instead of at the bulk load's rest (start_at_load_rest off).
            variants["pre_dura_z2"] = o;
            variants["pre_dura_z2"].noise.paired_test_z_with_pose = 2.0;
            variants["pre_dura_z1"] = o;
            variants["pre_dura_z1"].noise.paired_test_z_with_pose = 1.0;
            variants["pre_dura_start_only"] = o;
            variants["pre_dura_from_rest"] = o;
            variants["pre_dura_from_rest"].start_at_load_rest = false;
            // pre_dura_no_tail — every step of a stage's contracting tail taken, none jumped
            // (RegistrationOptions::extrapolate_tails off).
            variants["pre_dura_no_tail"] = o;
            variants["pre_dura_no_tail"].extrapolate_tails = false;
            methods.insert(methods.end(),
                           {"pre_dura", "pre_dura_z1", "pre_dura_z2", "pre_dura_start_only",
                            "pre_dura_from_rest", "pre_dura_no_tail"});
          }
          methods.insert(methods.end(), {"rigid_only", "prescribed_displacement"});
          for (const std::string& method : methods) {
            BenchRow row = base_row("cases", name);
            row.method = method;
            rows.push_back(measured(row, progress, [&](BenchRow& r) {
              describe(r, s, data);
              r.prepare_s = prepare_s;
              const std::string& m = method;
              const RegistrationResult res = median_of(args.repeat, [&] {
                return m == "rigid_only"            ? rigid_only(*s.model, data, o)
                       : m == "bulk_start_only"     ? constraints::start_only(*s.model, data, o)
                       : m == "pre_dura_start_only" ? constraints::start_only(*s.model, data_pre, o)
                       : m == "prescribed_displacement"
                           ? prescribed_displacement(*s.model, data, o)
                           : constraints::register_model(
                                 *s.model, m.rfind("pre_dura", 0) == 0 ? data_pre : data,
                                 variants.at(m));
              });
              score(r, *s.model, res, c, data);
              // Which vessel compliance the loop ended with (the noise model's choice, if applied).
              if (variants.count(m) && res.noise.valid)
                r.note = variants.at(m).noise.enabled
                             ? "vessel compliance: " + res.noise.message
                             : "vessel compliance fixed; " + res.noise.message;
            }));
            // The per-point predicted and actual errors of our default loop (dense calibration).
            if ((method == "constraint_icp" || method == "pre_dura") &&
                rows.back().unc_landmark_points) {
              const BenchRow& b = rows.back();
              std::filesystem::create_directories(dir / "dense");
              write_dense_csv(
                  dir / "dense" /
                      (name + (method == "constraint_icp" ? "" : "_" + method) + ".csv"),
                  &*b.unc_landmark_points, c.truth.a, c.truth.b,
                  b.unc_dense ? &*b.unc_dense : nullptr, c.dense.pre, c.dense.intra);
            }
            if (method == "constraint_icp")
              progress.stage(name + (c.dense.note.empty()
                                         ? ": dense truth reproduces the landmarks to " +
                                               std::to_string(c.dense.frame_fit_rms_mm) + " mm RMS"
                                         : ": no dense calibration: " + c.dense.note));
          }
          // elastix (--elastix): the image-registration peer on the same MRA and Doppler, its
          // rigid stage and rigid + B-spline from one run (baseline_elastix.hpp); the error in
          // the pre-operative frame.
          if (args.elastix) {
            progress.stage(name + ": elastix");
            const Eigen::Index nl = c.truth.b.rows(), nd = c.dense.intra.rows();
            MatrixX3d points(nl + nd, 3);  // the landmarks, then the dense points
            points << c.truth.b, c.dense.intra;
            const ElastixResult ex = elastix_register(c.phantom / "preop/mra.nii.gz",
                                                      c.phantom / "intraop/doppler.nii.gz",
                                                      c.phantom / "intraop/bmode.nii.gz", points,
                                                      work / name / "elastix", ElastixOptions{});
            for (const char* method : {"elastix_rigid", "elastix"}) {
              BenchRow row = base_row("cases", name);
              row.method = method;
              describe(row, s, data);
              row.prepare_s = 0.0;
              row.ok = ex.ok;
              row.error = ex.error;
              row.t.total = ex.seconds;
              row.stop = ex.ok ? "converged" : "failed";
              row.stop_reason =
                  "elastix: rigid then B-spline, Mattes MI, masked to the sweep; "
                  "error in the pre-operative frame";
              if (ex.ok) {
                const MatrixX3d& all = std::string(method) == "elastix" ? ex.bspline : ex.rigid;
                const MatrixX3d mapped = all.topRows(nl);
                const auto before =
                    imaging::error_stats(imaging::landmark_errors(c.truth.a, c.truth.b));
                const auto after =
                    imaging::error_stats(imaging::landmark_errors(mapped, c.truth.a));
                row.tre_before_mean = before.mean;
                row.tre_before_p95 = before.p95;
                row.tre_mean = after.mean;
                row.tre_p95 = after.p95;
                row.tre_max = after.max;
                row.tre_near_mean = row.tre_far_mean = std::nan("");
                row.corrected_pct = imaging::percent_shift_corrected(before.mean, after.mean);
                row.converged = true;
                if (nd > 0)
                  row.dense_error_mean = imaging::error_stats(imaging::landmark_errors(
                                                                  all.bottomRows(nd), c.dense.pre))
                                             .mean;
              }
              rows.push_back(row);
            }
          }
        } catch (const std::exception& e) {  // the case itself could not be built
          failed.error = e.what();
          rows.push_back(failed);
        }
      }

    if (do_sweeps) {
      const std::string name = "standard";
      try {
        const CaseData& c = case_data(name);

        // Mesh size: a model per refinement (the pre-operative cost is part of the figure).
        const std::vector<double> refine =
            args.quick
                ? std::vector<double>{0.85, 1.1}
                : std::vector<double>(std::begin(bench_refinements), std::end(bench_refinements));
        for (double r : refine) {
          BenchRow row = base_row("sweeps", name);
          row.sweep = "mesh_size";
          row.value = "refine " + fixed(r, 2);
          rows.push_back(measured(row, progress, [&](BenchRow& out_row) {
            const auto model_dir = work / name / ("model_r" + fixed(r, 2));
            out_row.prepare_s = prepare_case(c, model_dir, r);
            Session s = open_session(model_dir);
            constraints::IntraopData data;
            data.vessel_points = doppler_points(s, c, 2.5);
            describe(out_row, s, data);
            out_row.value = std::to_string(s.model->mesh().num_nodes()) + " nodes";
            score(out_row, *s.model,
                  median_of(args.repeat,
                            [&] {
                              return constraints::register_model(*s.model, data,
                                                                 product_options(s));
                            }),
                  c, data);
            std::filesystem::remove_all(
                model_dir);  // 50k-node models are large; the figures are kept
          }));
        }

        const auto model_dir = work / name / "model";
        if (!std::filesystem::exists(model_dir))
          standard_prepare_s = prepare_case(c, model_dir, 1.0);
        Session s = open_session(model_dir);
        constraints::IntraopData data;
        data.vessel_points = doppler_points(s, c, 2.5);
        auto sweep = [&](const std::string& what, const std::string& value,
                         const constraints::IntraopData& d, const RegistrationOptions& o,
                         constraints::RegistrationModel* model = nullptr) {
          BenchRow row = base_row("sweeps", name);
          row.sweep = what;
          row.value = value;
          rows.push_back(measured(row, progress, [&](BenchRow& r) {
            describe(r, s, d);
            r.prepare_s = standard_prepare_s.value_or(0.0);
            constraints::RegistrationModel& m = model ? *model : *s.model;
            score(r, m,
                  median_of(args.repeat, [&] { return constraints::register_model(m, d, o); }), c,
                  d);
          }));
        };

        // The start: identity, or the robust rigid fit (which also absorbs any bulk brain motion).
        for (const auto start :
             {constraints::RigidStart::IDENTITY, constraints::RigidStart::RIGID}) {
          RegistrationOptions o = product_options(s);
          o.start = start;
          sweep("start", start == constraints::RigidStart::RIGID ? "rigid" : "identity", data, o);
        }

        // Intra-operative vessel sampling.
        for (double step :
             args.quick ? std::vector<double>{5.0} : std::vector<double>{1.25, 2.5, 5.0}) {
          constraints::IntraopData d;
          d.vessel_points = doppler_points(s, c, step);
          sweep("vessel_sampling", fixed(step, 2) + " mm", d, product_options(s));
        }

        // Compliance strategy: the precomputed block (default), per-iteration sparse solves (a
        // model of its own: the strategy is chosen when the model is built), unwarped K0
        // (ablation).
        sweep("compliance", "dense_block", data, product_options(s));
        {
          constraints::ComplianceOptions sparse = s.loaded.scene.compliance;
          sparse.strategy = constraints::ComplianceStrategy::SPARSE_SOLVE;
          const auto& sc = s.loaded.scene;
          constraints::RegistrationModel m(sc.mesh, sc.fixed_nodes, sc.skeleton, sc.surface,
                                           sparse);
          sweep("compliance", "sparse_solve", data, product_options(s), &m);
        }
        {
          RegistrationOptions o = product_options(s);
          o.step.mechanics = constraints::Mechanics::UNWARPED;
          sweep("compliance", "unwarped_K0", data, o);
        }

        // PGS tolerance, with Gauss–Seidel forced (the default active-set solve is exact and
        // uses PGS only to verify).
        for (double tol : args.quick ? std::vector<double>{1e-2, 1e-4}
                                     : std::vector<double>{1e-2, 1e-3, 1e-4, 1e-6}) {
          RegistrationOptions o = product_options(s);
          o.step.solver = constraints::ConstraintSolver::GAUSS_SEIDEL;
          o.step.pgs.tolerance = tol;
          std::ostringstream v;
          v << "gs " << tol;
          sweep("pgs_tolerance", v.str(), data, o);
        }

        // Constraint sets.
        {
          constraints::IntraopData with_fp = data;
          const IntraopFootprint fp = footprint_from_bmode(c.phantom / "intraop/bmode.nii.gz");
          with_fp.footprint_points = fp.points;
          with_fp.footprint_normals = fp.normals;
          const std::string fp_note =
              fp.points.rows()
                  ? ""
                  : "the B-mode gave no footprint: " + fp.report.value("message", std::string());
          RegistrationOptions o = s.loaded.scene.options;
          o.use_footprint = false;
          sweep("constraint_sets", "vessels", data, o);
          o.use_footprint = true;
          sweep("constraint_sets", "vessels+footprint", with_fp, o);
          rows.back().note = fp_note;
          if (!args.quick) {
            o.dura.mode = constraints::DuraOptions::Mode::SLIDING;
            sweep("constraint_sets", "vessels+footprint+dura", with_fp, o);
            rows.back().note = fp_note;
          }
        }
      } catch (const std::exception& e) {
        BenchRow failed = base_row("sweeps", name);
        failed.error = e.what();
        rows.push_back(failed);
      }
    }

    // Growth with mesh size and constraint count.
    nlohmann::json fits = nlohmann::json::object();
    std::vector<std::pair<double, double>> reg, per_it, prep, wp;
    for (const BenchRow& r : rows) {
      if (!r.ok) continue;
      if (r.sweep == "mesh_size") {
        reg.emplace_back(r.nodes, r.t.total);
        if (r.iterations > 0) per_it.emplace_back(r.nodes, r.t.total / r.iterations);
        prep.emplace_back(r.nodes, r.prepare_s);
      }
      if ((r.sweep == "vessel_sampling" || r.sweep == "constraint_sets") && r.iterations > 0)
        wp.emplace_back(r.rows, (r.t.delassus + r.t.pgs) / r.iterations);
    }
    if (auto k = log_slope(reg)) fits["registration_s_vs_nodes"] = *k;
    if (auto k = log_slope(per_it)) fits["seconds_per_iteration_vs_nodes"] = *k;
    if (auto k = log_slope(prep)) fits["prepare_s_vs_nodes"] = *k;
    if (auto k = log_slope(wp)) fits["delassus_plus_pgs_per_iteration_vs_rows"] = *k;
    meta["fits"] = fits;

    const std::string plot = write_pareto(dir, rows);
    meta["plot"] = plot.empty() ? nlohmann::json("pareto.png") : nlohmann::json(plot);
    nlohmann::json all = meta;
    all["runs"] = nlohmann::json::array();
    for (const BenchRow& r : rows) all["runs"].push_back(row_json(r));
    write_csv(dir / "results.csv", rows);
    std::ofstream(dir / "results.json") << all.dump(2) << '\n';
    write_markdown(dir / "results.md", rows, meta);
    if (!args.keep_work) std::filesystem::remove_all(work);
  });
  return result;
}

}  // namespace brainshift::workflow
