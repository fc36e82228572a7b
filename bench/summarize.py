#!/usr/bin/env python3
"""Median tables and growth exponents from Google Benchmark JSON output (docs/BENCHMARKS.md).

usage: bench/summarize.py core.json constraints.json
Takes the *_median aggregate of each benchmark (or the single run where a benchmark ran once),
prints Markdown tables and the exponents of time ~ size^k fitted between consecutive sizes.
"""
import json
import math
import re
import sys


def load(paths):
    runs = {}
    for path in paths:
        with open(path) as f:
            data = json.load(f)
        for b in data["benchmarks"]:
            name = re.sub(r"/(iterations|repeats):\d+", "", b["run_name"])
            if b.get("error_occurred"):
                runs[name] = {"error": b.get("error_message", "error")}
                continue
            agg = b.get("aggregate_name")
            if agg == "median" or (agg is None and name not in runs):
                runs[name] = b
            if agg == "stddev" and name in runs:
                runs[name]["stddev_ms"] = b["real_time"]
    return runs


def ms(b):
    scale = {"ns": 1e-6, "us": 1e-3, "ms": 1.0, "s": 1e3}[b.get("time_unit", "ns")]
    return b["real_time"] * scale


def main():
    runs = load(sys.argv[1:])
    for name, b in sorted(runs.items()):
        if "error" in b:
            print(f"| {name} | skipped: {b['error']} |")
            continue
        extra = {k: v for k, v in b.items() if isinstance(v, (int, float)) and k not in (
            "real_time", "cpu_time", "iterations", "repetitions", "repetition_index", "threads",
            "family_index", "per_family_instance_index", "stddev_ms")}
        sd = b.get("stddev_ms")
        cv = f"{100 * sd * 1.0 / ms(b):.1f} %" if sd is not None and ms(b) > 0 else "–"
        print(f"| {name} | {ms(b):.4g} ms | cv {cv} | " +
              ", ".join(f"{k}={v:.4g}" for k, v in sorted(extra.items())) + " |")

    def exponent(family, key, sizes, size_counter):
        pts = []
        for s in sizes:
            b = runs.get(f"{family}/{key}:{s}")
            if b and "error" not in b:
                pts.append((b[size_counter], ms(b)))
        out = []
        for (n0, t0), (n1, t1) in zip(pts, pts[1:]):
            out.append(f"{n0:.0f}→{n1:.0f}: k = {math.log(t1 / t0) / math.log(n1 / n0):.2f}")
        return out

    print("\nGrowth with mesh size (time ~ nodes^k):")
    for fam in ("BM_AssembleK0", "BM_RestrictK0ff", "BM_CholmodAnalyze", "BM_CholmodFactorize",
                "BM_WarpedComplianceApply", "BM_ElementRotations", "BM_NodalRotations",
                "BM_InternalForce", "BM_InternalForceOnly"):
        print(fam, exponent(fam, "cells", (12, 26, 46), "nodes"))
    print("\nGrowth with rows (time ~ rows^k):")
    for fam in ("BM_W_DenseBlockPrecompute", "BM_W_DenseBlock", "BM_W_Sparse",
                "BM_W_SparseLowerSolveOnly", "BM_PGS", "BM_Step"):
        for cells in (12, 26):
            pts = []
            for r in (100, 300, 600, 1000, 3000):
                b = runs.get(f"{fam}/cells:{cells}/rows:{r}")
                if b and "error" not in b:
                    pts.append((r, ms(b)))
            ks = [f"{r0}→{r1}: {math.log(t1 / t0) / math.log(r1 / r0):.2f}"
                  for (r0, t0), (r1, t1) in zip(pts, pts[1:])]
            print(fam, f"cells {cells}", ks)


if __name__ == "__main__":
    main()
