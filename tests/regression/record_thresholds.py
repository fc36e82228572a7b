#!/usr/bin/env python3
"""Writes tests/regression/thresholds.json from one or more `brainshift bench --suite cases` runs.

Usage: tests/regression/record_thresholds.py [--seed N] A/results.json [B/results.json ...] \
         > tests/regression/thresholds.json
  e.g. three runs of the test's seed (three meshes) and two other seeds (for the spread):
       for i in 1 2 3; do brainshift bench --suite cases --out r$i; done
       brainshift bench --suite cases --seed 2 --out s2; brainshift bench --suite cases --seed 3 --out s3
       tests/regression/record_thresholds.py r1/results.json r2/results.json r3/results.json \
         s2/results.json s3/results.json > tests/regression/thresholds.json
Per case it records the worst figures over the runs at the test's seed and reports (under
"measured") the run-to-run spread over all seeds; see "Aggregation" below for why.

Run the bench with the real data (`--real-data ../shared/data`, the default from the project root)
so that the ICBM152 cases (icbm_standard, icbm_offset_20mm; issue 18) are recorded too. A case the
runs skipped (results.json -> skipped: the real data were absent) keeps its entry from
`--keep OLD_thresholds.json` when given (write to a new file, then move it over the old one).

The recorded figures are the constraint-ICP runs (Release build, the seed of the run); the test
allows mean TRE up to recorded x tre_factor + tre_add_mm, shift corrected down to recorded -
corrected_pct_drop, and mean TRE at most rigid-only + margin.rigid_gap_mm (test_regression.cpp:
issue 14 item 3, a gap of 0 plus a stated noise margin; no shortfall is recorded).
The margins cover what varies between machines and builds without a code change: CGAL's sliver exudation is not bit-reproducible, so the mesh (and with it the pairing of a
few points) differs slightly from run to run. Measured on 2026-12-01 (three full `bench --suite
cases` runs of the same code, three meshes per case): our mean TRE varied by at most 0.023 mm
(offset_12mm), the stop was `converged` in all 30 runs, and rigid-only did not vary at all. The
margin on our own figure (x 1.1 + 0.15 mm, 5 points of shift corrected) is about 5-10x that
spread: wide enough not to flake, narrow enough that a 15 % regression fails.

The gap to rigid-only: the test allows rigid_gap_mm (0.1 mm), about four times the largest
run-to-run spread measured on our mean TRE (0.023 mm); rigid-only does not use the mesh and does
not vary. This script refuses to record a run whose gap at the test's seed exceeds it. Since
2026-12-03 (the start's bulk shift bounded to a sag, the noise model's paired test on by default)
the gap is 0 on all 36 runs of 12 cases x seeds 1-3 (docs/history/BENCHMARKS_NOTEBOOK.md, v7).

The same over the whole brain (bench's dense_error_mean_mm: 500 points drawn uniformly in the
brain, their truth from the phantom's truth field): the test allows dense_rigid_gap_mm (0.3 mm).
Margin: two runs of seed 1 on one machine gave identical figures, so the spread to cover is the
meshing noise between machines, measured at up to 0.023 mm on the landmark TRE (above); the dense
mean moves with the whole pose (9-15 mm lever arms against the landmarks' 5-40 mm), so 0.3 mm:
about 10x that TRE spread and about 3 % of the whole-brain error (8-15 mm). This script refuses a
run whose whole-brain gap at the test's seed exceeds it.

The main path, a pose from the pre-dura sweep (bench's pre_dura run, in the same results.json):
its mean TRE at the landmarks and over the whole brain are recorded too (pre_dura_tre_mean_mm,
pre_dura_dense_error_mean_mm), the worst over the runs at the test's seed, and the test allows
the same x 1.1 + 0.15 mm at the landmarks and x 1.1 + dense_add_mm (0.3 mm, the whole-brain
margin above) over the brain. Measured on 2026-12-07: two seed-1 runs of all 13 cases gave
identical pre-dura figures on one machine (the meshing noise between machines is the TRE spread
above).

The block-CV noise model at its CV minimum (`bench` variant block_cv) was bimodal with the mesh:
deep_tumour_one_side_vessels 1.92 or 3.13 mm and tracking_error 3.08 or 3.42 mm from the same
seed, because its CV curve has two nearly equal minima and CGAL's meshing is not
bit-reproducible. Thresholds of a bimodal loop cannot be recorded from a few runs; this script's
spread check refuses them. The default's paired test decides between two states (the start, or
the deformation at the CV minimum) and keeps the start on 35 of 36 phantom runs.
"""
import argparse
import json
import sys

# The seed `brainshift bench` uses when none is given (apps/cmd_bench.hpp, BenchArgs::seed): the
# phantoms test_regression.cpp replays.
TEST_SEED = 1

ap = argparse.ArgumentParser(description="thresholds.json from one or more `bench --suite cases` results.json")
ap.add_argument("results", nargs="+", help="results.json of `brainshift bench --suite cases [--seed N]` runs")
ap.add_argument("--seed", type=int, default=TEST_SEED,
                help=f"the seed the regression test replays (default {TEST_SEED}, bench's default)")
ap.add_argument("--keep", metavar="OLD_THRESHOLDS",
                help="thresholds.json whose entries are kept for cases the runs skipped (real data absent)")
args = ap.parse_args()

# Per file (one bench process: one mesh per case) and case, our run and its rigid-only baseline.
samples = {}  # case -> seed -> list of {tre, pct, before, gap, file}
dates, build_types, skipped = set(), set(), set()
for path in args.results:
    try:
        runs = json.load(open(path))
        rows = runs["runs"]
    except (OSError, ValueError, KeyError, TypeError) as e:
        sys.exit(f"record_thresholds.py: {path}: not a bench results.json ({e})")
    skipped.update(runs.get("skipped", []))
    dates.add(runs["machine"]["date"])
    build_types.add(runs["machine"]["build_type"])
    rigid = {(r["case"], r["seed"]): r["tre_mean_mm"] for r in rows
             if r["suite"] == "cases" and r["method"] == "rigid_only" and r["ok"]}
    rigid_dense = {(r["case"], r["seed"]): r.get("dense_error_mean_mm") for r in rows
                   if r["suite"] == "cases" and r["method"] == "rigid_only" and r["ok"]}
    pre_dura = {(r["case"], r["seed"]): r for r in rows
                if r["suite"] == "cases" and r["method"] == "pre_dura" and r["ok"]}
    for r in rows:
        if r["suite"] != "cases" or r["method"] != "constraint_icp":
            continue
        if not r["ok"]:
            sys.exit(f"record_thresholds.py: {path}: case {r['case']} (seed {r['seed']}) failed: {r.get('error')}")
        if (r["case"], r["seed"]) not in rigid:
            sys.exit(f"record_thresholds.py: {path}: case {r['case']} (seed {r['seed']}) has no rigid_only run")
        samples.setdefault(r["case"], {}).setdefault(r["seed"], []).append({
            "tre": r["tre_mean_mm"],
            "pct": r["shift_corrected_pct"] or 0.0,
            "before": r["tre_before_mean_mm"],
            "gap": max(0.0, r["tre_mean_mm"] - rigid[(r["case"], r["seed"])]),
            "dense_gap": (max(0.0, r["dense_error_mean_mm"] - rigid_dense[(r["case"], r["seed"])])
                          if r.get("dense_error_mean_mm") is not None
                          and rigid_dense.get((r["case"], r["seed"])) is not None else None),
            "stop": r["stop"],
            "file": path,
            "pre_dura": pre_dura.get((r["case"], r["seed"])),
        })
if not samples:
    sys.exit("record_thresholds.py: no successful constraint_icp run of the cases suite in the given files")
if len(build_types) != 1 or "Release" not in build_types:
    sys.exit(f"record_thresholds.py: record from Release builds only (got {sorted(build_types)})")

# Aggregation. The recorded figure of a case is the WORST over the runs at the test's seed
# (largest mean TRE, smallest shift corrected, largest gap to rigid): each bench process meshes the
# phantom anew and CGAL's meshing is not bit-reproducible, so these runs sample the run-to-run noise
# the test will meet, and with the 2-5 runs we can afford the worst is a safer bound than mean +
# k·spread (whose spread from 3 samples is itself unreliable). Runs at OTHER seeds are other
# phantoms (another vessel tree and noise): the test never replays them, and their seed-to-seed
# range (often tenths of a mm) would widen every threshold by far more than the noise, which is
# what issue 19 found wrong. They serve to measure the same-seed (mesh) spread on more phantoms:
# the largest max-min over the runs of one seed, over all seeds, is reported below and must stay
# well inside the margin (checked after `margin` is set).
cases, spread, seed_range = {}, {}, {}
for case, by_seed in samples.items():
    at = by_seed.get(args.seed)
    if not at:
        sys.exit(f"record_thresholds.py: case {case}: no run at the test's seed {args.seed} "
                 f"(seeds given: {sorted(by_seed)}); run `bench --suite cases --seed {args.seed}` too")
    befores = [s["before"] for s in at]
    if max(befores) - min(befores) > 2e-3:
        sys.exit(f"record_thresholds.py: case {case}: the before error differs between runs of seed {args.seed} "
                 f"({min(befores):.4f}-{max(befores):.4f} mm): the phantom is not reproducible")
    cases[case] = {
        "tre_mean_mm": max(s["tre"] for s in at),
        "shift_corrected_pct": min(s["pct"] for s in at),
        "tre_before_mean_mm": befores[0],
        "rigid_gap_mm": max(s["gap"] for s in at),
    }
    # The main path (a pre-dura pose; issue 32): its landmarks and whole brain, the worst runs.
    pd = [s["pre_dura"] for s in at if s["pre_dura"] is not None]
    if pd:
        cases[case]["pre_dura_tre_mean_mm"] = max(p["tre_mean_mm"] for p in pd)
        dense_pd = [p["dense_error_mean_mm"] for p in pd if p.get("dense_error_mean_mm") is not None]
        if dense_pd:
            cases[case]["pre_dura_dense_error_mean_mm"] = max(dense_pd)
    dense = [s["dense_gap"] for s in at if s["dense_gap"] is not None]
    if dense:
        cases[case]["dense_gap_to_rigid_mm"] = max(dense)
    spread[case] = max(max(s["tre"] for s in v) - min(s["tre"] for s in v) for v in by_seed.values())
    worst_by_seed = [max(s["tre"] for s in v) for v in by_seed.values()]
    seed_range[case] = (min(worst_by_seed), max(worst_by_seed))
# Runs that the thresholds cannot describe, on any seed: said on stderr (the output stays valid).
for case, by_seed in sorted(samples.items()):
    for seed, v in sorted(by_seed.items()):
        for smp in v:
            if smp["stop"] != "converged" or smp["gap"] > 0.5:
                print(f"record_thresholds.py: warning: {case} seed {seed} ({smp['file']}): stop {smp['stop']}, mean TRE "
                      f"{smp['tre']:.3f} mm, {smp['gap']:.3f} mm worse than rigid only", file=sys.stderr)
runs = {"machine": {"date": ", ".join(sorted(dates)), "build_type": build_types.pop()}, "seed": args.seed}
per_case_runs = {c: {str(seed): len(v) for seed, v in sorted(by_seed.items())} for c, by_seed in samples.items()}

MARGIN = {"tre_factor": 1.1, "tre_add_mm": 0.15, "corrected_pct_drop": 5.0, "rigid_gap_mm": 0.1,
          "dense_rigid_gap_mm": 0.3, "dense_add_mm": 0.3}
# The suite asserts a gap to rigid alone of 0 plus the margin (issue 14 item 3): a run behind it
# at the test's seed is not a figure to record but a failure to fix.
for name, c in sorted(cases.items()):
    if c["rigid_gap_mm"] > MARGIN["rigid_gap_mm"]:
        sys.exit(f"record_thresholds.py: case {name}: mean TRE {c['rigid_gap_mm']:.3f} mm behind rigid alone at seed "
                 f"{args.seed}, more than the margin {MARGIN['rigid_gap_mm']} mm the test allows")
    if c.get("dense_gap_to_rigid_mm", 0.0) > MARGIN["dense_rigid_gap_mm"]:
        sys.exit(f"record_thresholds.py: case {name}: whole-brain error {c['dense_gap_to_rigid_mm']:.3f} mm behind "
                 f"rigid alone at seed {args.seed}, more than the margin {MARGIN['dense_rigid_gap_mm']} mm")
for c in cases.values():
    c.pop("rigid_gap_mm")
    c.pop("dense_gap_to_rigid_mm", None)
    c.update({
        "tre_mean_mm": round(c["tre_mean_mm"], 3),
        "shift_corrected_pct": round(c["shift_corrected_pct"], 1),
        "tre_before_mean_mm": round(c["tre_before_mean_mm"], 3),
    })
    for key in ("pre_dura_tre_mean_mm", "pre_dura_dense_error_mean_mm"):
        if key in c:
            c[key] = round(c[key], 3)
skipped -= set(cases)
if skipped:
    kept = json.load(open(args.keep))["cases"] if args.keep else {}
    for name in sorted(skipped):
        if name in kept:
            cases[name] = kept[name]
    print("record_thresholds.py: the runs skipped " + ", ".join(sorted(skipped)) +
          (f" (kept from {args.keep} where recorded)" if args.keep else " (left out: pass --keep OLD_thresholds.json)"),
          file=sys.stderr)
out = {
    "_comment": "Recorded by tests/regression/record_thresholds.py from `brainshift bench --suite cases` "
    f"({runs['machine']['date']}, {runs['machine']['build_type']}, seed {runs['seed']}); see that script for the margin.",
    "margin": MARGIN,
    "cases": cases,
}
# The margin must dwarf the measured same-seed spread, or the test would flake: the allowance of the
# tightest case (recorded x (factor - 1) + add) at least 3x the largest spread measured.
m = out["margin"]
allowance = min(c["tre_mean_mm"] * (m["tre_factor"] - 1) + m["tre_add_mm"] for c in cases.values())
worst_spread = max(spread.values())
if allowance < 3 * worst_spread:
    sys.exit(f"record_thresholds.py: the margin allows {allowance:.3f} mm on the tightest case, less than 3x the "
             f"measured run-to-run spread {worst_spread:.3f} mm: widen the margin or find the noise")
out["measured"] = {
    "_comment": "runs per case and seed; tre_spread_mm: the largest max-min of our mean TRE over runs of one seed "
    "(meshing noise, 0 with one run per seed); tre_over_seeds_mm: the smallest and largest over seeds of the per-seed worst mean TRE "
    "(other phantoms: reported, not used)",
    "files": len(args.results),
    "cases": {c: {"runs": per_case_runs[c], "tre_spread_mm": round(spread[c], 4),
                  "tre_over_seeds_mm": [round(x, 3) for x in seed_range[c]]} for c in cases},
}
json.dump(out, sys.stdout, indent=2)
print()
