#!/usr/bin/env python3
"""Writes tests/regression/thresholds.json from a `brainshift bench --suite cases` run.

Usage: tests/regression/record_thresholds.py DIR/results.json [OLD_thresholds.json] > NEW_thresholds.json

Run the bench with the real data (`--real-data ../shared/data`, the default from the project root)
so that the ICBM152 cases (icbm_standard, icbm_offset_20mm; issue 18) are recorded too. A case the
run skipped (results.json -> skipped: the real data were absent) keeps its entry from
OLD_thresholds.json when given (write to a new file, then move it over the old one); without it the
case is left out and its regression test fails with "no recorded figures" when the data are there.

The recorded figures are the constraint-ICP runs (Release build, the seed of the run); the test
allows mean TRE up to recorded x tre_factor + tre_add_mm, shift corrected down to recorded -
corrected_pct_drop, and mean TRE at most rigid-only + margin.rigid_gap_mm on every case
(test_regression.cpp: the gap to rigid is 0 plus a noise margin, issue 14; no recorded shortfall).
The margins cover what varies between machines and builds without a code change: CGAL's sliver exudation is not bit-reproducible, so the mesh (and with it the pairing of a
few points) differs slightly from run to run. Measured on 2026-12-01 (three full `bench --suite
cases` runs of the same code, three meshes per case): our mean TRE varied by at most 0.023 mm
(offset_12mm), the stop was `converged` in all 30 runs, and rigid-only did not vary at all. The
margin on our own figure (x 1.1 + 0.15 mm, 5 points of shift corrected) is about 5-10x that
spread: wide enough not to flake, narrow enough that a 15 % regression fails.

The gap to rigid-only (rigid_gap_mm = 0.15 mm) is what the data cannot tell apart. The loop picks
the vessel rows' compliance by leave-one-branch-out cross-validation at its minimum; on the near-rigid
cases (standard, offset_*, noisy_doppler) the deformation it keeps and the rigid answer predict the
held-out vessels within one standard error of each other, and land 0.05-0.11 mm apart in mean TRE
(measured 2026-12-02). Taking the rigid answer whenever the two are within one standard error (the
one-SE rule, NoiseOptions::one_standard_error) closes that gap but also throws away the deformation
where it is worth 1.2 mm off the vessels (deep_tumour_one_side_vessels). So the margin is the CV's
resolution on these cases (0.11 mm) plus twice the run-to-run spread of our mean TRE (0.023 mm),
rounded up; a real loss to rigid (0.21-0.51 mm before the block-CV noise model) still fails.
"""
import json
import sys

runs = json.load(open(sys.argv[1]))
rigid = {r["case"]: r["tre_mean_mm"] for r in runs["runs"]
         if r["suite"] == "cases" and r["method"] == "rigid_only" and r["ok"]}
cases = {}
for r in runs["runs"]:
    if r["suite"] == "cases" and r["method"] == "constraint_icp" and r["ok"]:
        cases[r["case"]] = {
            "tre_mean_mm": round(r["tre_mean_mm"], 3),
            "shift_corrected_pct": round(r["shift_corrected_pct"] or 0.0, 1),
            "tre_before_mean_mm": round(r["tre_before_mean_mm"], 3),
            # Recorded for the reader (the test asserts gap <= margin.rigid_gap_mm, not this).
            "gap_to_rigid_mm": round(r["tre_mean_mm"] - rigid[r["case"]], 3),
        }
skipped = runs.get("skipped", [])
if len(sys.argv) > 2:
    old = json.load(open(sys.argv[2]))["cases"]
    for name in skipped:
        if name in old and name not in cases:
            cases[name] = old[name]
if skipped:
    print("record_thresholds: the run skipped " + ", ".join(skipped) +
          (" (kept from " + sys.argv[2] + ")" if len(sys.argv) > 2 else " (left out: pass the old thresholds.json)"),
          file=sys.stderr)
out = {
    "_comment": "Recorded by tests/regression/record_thresholds.py from `brainshift bench --suite cases` "
    f"({runs['machine']['date']}, {runs['machine']['build_type']}, seed {runs['seed']}); see that script for the margin.",
    "margin": {"tre_factor": 1.1, "tre_add_mm": 0.15, "corrected_pct_drop": 5.0, "rigid_gap_mm": 0.15},
    "cases": cases,
}
json.dump(out, sys.stdout, indent=2)
print()
