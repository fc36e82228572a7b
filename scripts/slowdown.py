#!/usr/bin/env python3
"""Flags a test that became about 10x slower than its recorded time (issue 19 item 5).

CTest keeps each test's running time (average of its last runs) in
BUILD/Testing/Temporary/CTestCostData.txt. This compares them with tests/test_times.txt, the
times recorded on a quiet run. Machines differ, so every ratio time / recorded is divided by the
median ratio over all tests that ran (the machine's speed relative to the recording); a test is
flagged when that normalised ratio exceeds --factor (default 10) and it took more than --floor
seconds (default 2: below that a test is mostly process start-up and noise). A per-test TIMEOUT
cannot do this: it is one number per executable, far above its fast tests (tests/README.md).

Usage:
  scripts/slowdown.py [BUILD]            check (scripts/test.sh runs it after ctest)
  scripts/slowdown.py [BUILD] --record   write tests/test_times.txt from BUILD's last run
"""
import argparse
import statistics
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def read_costs(path):
    costs = {}
    if not path.exists():
        return costs
    for line in path.read_text().splitlines():
        if line.startswith("---"):
            break  # the failed-tests section follows
        parts = line.split()
        if len(parts) == 3:
            try:
                costs[parts[0]] = float(parts[2])
            except ValueError:
                pass
    return costs


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("build", nargs="?", type=Path, default=ROOT / "build")
    ap.add_argument("--baseline", type=Path, default=ROOT / "tests" / "test_times.txt")
    ap.add_argument("--record", action="store_true")
    ap.add_argument("--factor", type=float, default=10.0)
    ap.add_argument("--floor", type=float, default=2.0)
    a = ap.parse_args()
    cost_file = a.build / "Testing" / "Temporary" / "CTestCostData.txt"
    costs = read_costs(cost_file)
    if a.record:
        if not costs:
            sys.exit(f"slowdown.py: {cost_file}: no test times (run ctest first)")
        lines = [f"{n} {t:.3f}" for n, t in sorted(costs.items())]
        a.baseline.write_text("# test seconds (CTest cost data of a quiet run; scripts/slowdown.py --record)\n"
                              + "\n".join(lines) + "\n")
        print(f"slowdown.py: recorded {len(lines)} test times in {a.baseline}")
        return
    base = {}
    for line in a.baseline.read_text().splitlines():
        if line and not line.startswith("#"):
            n, t = line.split()
            base[n] = float(t)
    common = [n for n in costs if n in base and base[n] > 0 and costs[n] > 0]
    if len(common) < 10:
        print(f"slowdown.py: only {len(common)} tests with a recorded time ran; nothing to compare")
        return
    speed = statistics.median(costs[n] / base[n] for n in common)
    slow = sorted(((costs[n] / base[n] / speed, n) for n in common
                   if costs[n] > a.floor and costs[n] / base[n] / speed > a.factor), reverse=True)
    print(f"slowdown.py: {len(common)} tests compared with {a.baseline.name}; this machine runs "
          f"them {speed:.2f}x the recorded time (median)")
    for r, n in slow:
        print(f"slowdown.py: {n} took {costs[n]:.1f} s, {r:.1f}x its recorded {base[n]:.2f} s "
              f"(machine-normalised; limit {a.factor:g}x)", file=sys.stderr)
    if slow:
        sys.exit(1)


if __name__ == "__main__":
    main()
