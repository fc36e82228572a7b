#!/usr/bin/env python3
"""How each stage of the registration grows with the model's node count (docs/BENCHMARKS.md).

usage: bench/scaling.py [--bin build/apps/brainshift] [--case standard] [--seed 1]
                        [--refine 1,1.5,2,2.8] [--repeat 3] --out DIR
       bench/scaling.py --self-test

One phantom (`brainshift phantom`), one model per refinement (`prepare --refine R`), the
pre-dura pose measured once per model (`pre-dura`), then `register --pre-dura-pose` repeated
--repeat times per model: the surgical session's main path. Each stage's seconds are read from
report.json's `timing` (medians over the repeats); the loop's stages are also divided by the
iterations (their cost per iteration, which is what the mesh size drives; the iteration count is
the loop's own). The growth of each is the slope k of log t = k log n + c fitted by least
squares over the sizes (t ∝ n^k), with its coefficient of determination r².
Writes DIR/scaling.csv (one row per size) and DIR/scaling.md (the table and the fits); prints the
latter. A run that ends with exit 2 (not converged) is kept: its report has the same timings.
"""
import argparse
import csv
import json
import math
import os
import statistics
import subprocess
import sys

STAGES = ["rigid", "pairing", "free_motion", "delassus", "pgs", "correction", "noise",
          "registration"]
PER_ITERATION = ["pairing", "free_motion", "delassus", "pgs", "correction"]


def fit_power(ns, ts):
    """Least-squares slope k and r² of log t against log n (t ∝ n^k); None without two sizes
    with positive times."""
    pts = [(math.log(n), math.log(t)) for n, t in zip(ns, ts) if n > 0 and t > 0]
    if len(pts) < 2:
        return None
    mx = sum(x for x, _ in pts) / len(pts)
    my = sum(y for _, y in pts) / len(pts)
    sxx = sum((x - mx) ** 2 for x, _ in pts)
    if sxx == 0:
        return None
    k = sum((x - mx) * (y - my) for x, y in pts) / sxx
    c = my - k * mx
    ss_res = sum((y - (k * x + c)) ** 2 for x, y in pts)
    ss_tot = sum((y - my) ** 2 for _, y in pts)
    r2 = 1.0 - ss_res / ss_tot if ss_tot > 0 else 1.0
    return k, r2


def self_test():
    """The fit against closed forms: exact power laws give their exponent and r² = 1; a
    constant gives 0; noise lowers r² below 1."""
    ns = [1600, 4000, 9000, 21000]
    for k in (0.0, 1.0, 1.5, 2.0):
        got, r2 = fit_power(ns, [3e-4 * n ** k for n in ns])
        assert abs(got - k) < 1e-12 and abs(r2 - 1) < 1e-12, (k, got, r2)
    got, r2 = fit_power(ns, [n * (1.3 if i % 2 else 0.7) for i, n in enumerate(ns)])
    assert 0.5 < got < 1.5 and r2 < 1, (got, r2)
    assert fit_power([1000], [1.0]) is None and fit_power([1000, 1000], [1.0, 2.0]) is None
    print("scaling.py self-test: the fit recovers power laws exactly")


def run(cmd, ok=(0,)):
    p = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    if p.returncode not in ok:
        sys.exit(f"scaling.py: {' '.join(cmd)} failed ({p.returncode}):\n{p.stdout[-2000:]}")
    return p.stdout


def nodes_of(model_dir):
    with open(os.path.join(model_dir, "model.json")) as f:
        m = json.load(f)
    for key in ("nodes", "num_nodes"):
        if key in m:
            return int(m[key])
        if key in m.get("mesh", {}):
            return int(m["mesh"][key])
    sys.exit(f"scaling.py: no node count in {model_dir}/model.json")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bin", default="build/apps/brainshift")
    ap.add_argument("--case", default="standard")
    ap.add_argument("--seed", default="1")
    ap.add_argument("--refine", default="1,1.5,2,2.8")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--out")
    ap.add_argument("--self-test", action="store_true")
    a = ap.parse_args()
    if a.self_test:
        self_test()
        return
    if not a.out:
        ap.error("--out is required")
    os.makedirs(a.out, exist_ok=True)
    phantom = os.path.join(a.out, "P")
    if not os.path.isdir(phantom):
        run([a.bin, "phantom", "--case", a.case, "--seed", a.seed, "--out", phantom])
    pre = os.path.join(phantom, "preop")
    intra = os.path.join(phantom, "intraop")
    rows = []
    for r in [float(x) for x in a.refine.split(",")]:
        model = os.path.join(a.out, f"M{r:g}")
        if not os.path.isdir(model):
            run([a.bin, "prepare", "--labels", f"{pre}/labels.nii.gz", "--mra", f"{pre}/mra.nii.gz",
                 "--mri", f"{pre}/mri.nii.gz", "--refine", f"{r:g}", "--out", model])
        pose = os.path.join(a.out, f"pose{r:g}.json")
        run([a.bin, "pre-dura", "--model", model, "--doppler",
             f"{intra}/predura/doppler.nii.gz", "--out", pose])
        reports = []
        for i in range(a.repeat):
            res = os.path.join(a.out, f"R{r:g}_{i}")
            run([a.bin, "register", "--model", model, "--doppler", f"{intra}/doppler.nii.gz",
                 "--pre-dura-pose", pose, "--out", res], ok=(0, 2))
            with open(os.path.join(res, "report.json")) as f:
                reports.append(json.load(f))
        row = {"refine": r, "nodes": nodes_of(model),
               "iterations": statistics.median(rep["iterations"] for rep in reports),
               "stop": reports[-1]["stop"]}
        for s in STAGES:
            row[s] = statistics.median(rep["timing"].get(s, 0.0) for rep in reports)
        for s in PER_ITERATION:
            row[s + "_per_iteration"] = statistics.median(
                rep["timing"].get(s, 0.0) / max(rep["iterations"], 1) for rep in reports)
        rows.append(row)
        print(f"refine {r:g}: {row['nodes']} nodes, {row['iterations']:g} iterations, "
              f"registration {row['registration']:.3f} s ({row['stop']})", flush=True)

    with open(os.path.join(a.out, "scaling.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        w.writeheader()
        w.writerows(rows)
    ns = [row["nodes"] for row in rows]
    lines = ["| nodes | iterations | stop | " + " | ".join(STAGES) + " |",
             "|" + "---|" * (len(STAGES) + 3)]
    for row in rows:
        lines.append(f"| {row['nodes']} | {row['iterations']:g} | {row['stop']} | " +
                     " | ".join(f"{row[s]:.3f}" for s in STAGES) + " |")
    lines += ["", "| cost | slope k (t ∝ n^k) | r² |", "|---|--:|--:|"]
    for key in STAGES + [s + "_per_iteration" for s in PER_ITERATION] + ["iterations"]:
        f = fit_power(ns, [row[key] for row in rows])
        lines.append(f"| {key} | " + (f"{f[0]:.2f} | {f[1]:.3f} |" if f else "— | — |"))
    text = "\n".join(lines) + "\n"
    with open(os.path.join(a.out, "scaling.md"), "w") as f:
        f.write(text)
    print(text)


if __name__ == "__main__":
    main()
