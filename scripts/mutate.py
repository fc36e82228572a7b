#!/usr/bin/env python3
"""A small mutation check of our own (issue 19 item 4): does a failing test catch each planted bug?

Applies the one-line mutants of a list (default tests/mutants.txt) one at a time to the worktree,
rebuilds the named targets incrementally in an existing build folder, runs the named CTest tests
with a timeout, and restores the file. A mutant is KILLED when a test fails (or times out), SURVIVED
when all its tests pass. Exit status: 0 all killed, 1 some survived, 2 a usage, list, build or
baseline error (a mutant that does not compile is an error of the list, not a kill).

Usage:
  scripts/mutate.py BUILD_DIR [--list tests/mutants.txt] [--only NAME[,NAME]] [--timeout S]
                    [--no-baseline] [--jobs N]
  e.g. scripts/mutate.py build                 # every mutant, Release build folder `build`
       scripts/mutate.py build --only pgs_clamp_sign

Safety: the original bytes of the mutated file are kept in memory and in BUILD_DIR/mutate-journal.json
before the mutant is written; the file is restored in a `finally` (also on Ctrl-C / SIGTERM, which
are turned into exceptions), and a journal left by a killed run is restored on the next start. A
file with uncommitted changes is mutated all the same (its current bytes are what is restored).
After the last mutant the touched files are rebuilt once more so the build folder matches the
sources again.

List format (tests/mutants.txt): blocks separated by blank lines, `key: value` lines, `#` comments.
  name:    unique identifier
  file:    path from the repository root
  from:    exact text of the original (must occur exactly once in the file)
  to:      its replacement
  targets: build targets to rebuild (space separated)
  tests:   CTest -R regular expression naming the tests that should kill it
  why:     (optional) what the mutant breaks
"""
import argparse
import json
import re
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def parse_list(path):
    mutants, block = [], {}
    keys = {"name", "file", "from", "to", "targets", "tests", "why"}
    for n, raw in enumerate(path.read_text().splitlines() + [""], 1):
        line = raw.rstrip()
        if line.lstrip().startswith("#"):
            continue
        if not line.strip():
            if block:
                missing = {"name", "file", "from", "to", "targets", "tests"} - block.keys()
                if missing:
                    sys.exit(f"mutate.py: {path}:{n}: mutant {block.get('name', '?')} lacks {sorted(missing)}")
                mutants.append(block)
                block = {}
            continue
        key, sep, value = line.partition(":")
        if not sep or key.strip() not in keys:
            sys.exit(f"mutate.py: {path}:{n}: expected 'key: value' with key in {sorted(keys)}")
        block[key.strip()] = value[1:] if value.startswith(" ") else value
    names = [m["name"] for m in mutants]
    dup = {x for x in names if names.count(x) > 1}
    if dup:
        sys.exit(f"mutate.py: {path}: duplicate mutant names {sorted(dup)}")
    return mutants


class Interrupted(Exception):
    pass


def on_signal(signum, _frame):
    raise Interrupted(f"signal {signum}")


def restore_journal(journal):
    if not journal.exists():
        return
    j = json.loads(journal.read_text())
    Path(j["path"]).write_bytes(bytes.fromhex(j["original_hex"]))
    journal.unlink()
    print(f"mutate.py: restored {j['path']} from a journal left by an interrupted run", flush=True)


def run(cmd, timeout=None, log=None):
    """Runs cmd; returns (exit status or 'timeout', combined output)."""
    try:
        p = subprocess.run(cmd, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                           timeout=timeout)
        out = p.stdout
        status = p.returncode
    except subprocess.TimeoutExpired as e:
        out = (e.stdout or b"").decode() if isinstance(e.stdout, bytes) else (e.stdout or "")
        status = "timeout"
    if log:
        with open(log, "a") as f:
            f.write(f"$ {' '.join(cmd)}\n{out}\n[status {status}]\n")
    return status, out


def build(build_dir, targets, jobs, log):
    return run(["cmake", "--build", str(build_dir), "-j", str(jobs), "--target", *targets], log=log)[0] == 0


def ctest(build_dir, regex, timeout, log):
    # ctest's own --timeout caps each test; the outer timeout catches a hang of ctest itself.
    status, out = run(["ctest", "--test-dir", str(build_dir), "-R", regex, "--timeout", str(timeout),
                       "-j", "1", "--output-on-failure"], timeout=timeout * 50 + 60, log=log)
    if "No tests were found" in out:
        return "notests", out
    return ("pass" if status == 0 else "fail"), out


def test_names(build_dir, regex):
    """The CTest tests that a -R regex selects (ctest -N)."""
    _, out = run(["ctest", "--test-dir", str(build_dir), "-N", "-R", regex])
    return [line.split(":", 1)[1].strip() for line in out.splitlines() if line.strip().startswith("Test") and "#" in line]


def exact_regexes(names, chunk=20):
    """Regexes selecting exactly these tests, in chunks (CMake's regex allows few groups and a short program)."""
    esc = [re.escape(n) for n in sorted(names)]
    return ["|".join(f"^{n}$" for n in esc[i:i + chunk]) for i in range(0, len(esc), chunk)]


def check_applies(mutants):
    """Exits naming the first mutant whose file is missing or whose text is not there exactly once."""
    for m in mutants:
        path = ROOT / m["file"]
        if not path.exists():
            sys.exit(f"mutate.py: mutant {m['name']}: no file {m['file']}")
        count = path.read_text().count(m["from"])
        if count != 1:
            sys.exit(f"mutate.py: mutant {m['name']}: '{m['from']}' occurs {count} times in {m['file']} (need 1)")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("build_dir", type=Path, nargs="?",
                    help="an existing, configured build folder (e.g. build); not needed with --check")
    ap.add_argument("--check", action="store_true",
                    help="only check that every mutant applies (its text exactly once); no build (lint.sh runs it)")
    ap.add_argument("--list", type=Path, default=ROOT / "tests" / "mutants.txt")
    ap.add_argument("--only", default="", help="comma-separated mutant names")
    ap.add_argument("--timeout", type=int, default=120, help="ctest --timeout: seconds for a test without its own TIMEOUT (ours all have one, "
                    "which applies); the whole ctest call is capped at 50x this + 60 s")
    ap.add_argument("--no-baseline", action="store_true", help="skip the unmutated run of the named tests")
    ap.add_argument("--jobs", type=int, default=1)
    a = ap.parse_args()
    if a.check:
        check_applies(parse_list(a.list))
        print(f"mutate.py: all mutants of {a.list.name} apply")
        return
    if a.build_dir is None:
        ap.error("build_dir is required (except with --check)")
    build_dir = a.build_dir if a.build_dir.is_absolute() else (Path.cwd() / a.build_dir)
    if not (build_dir / "CMakeCache.txt").exists():
        sys.exit(f"mutate.py: {build_dir} is not a configured build folder (no CMakeCache.txt)")
    journal = build_dir / "mutate-journal.json"
    restore_journal(journal)  # first of all: a run killed outright left a mutant in the worktree
    mutants = parse_list(a.list)
    if a.only:
        want = set(a.only.split(","))
        unknown = want - {m["name"] for m in mutants}
        if unknown:
            sys.exit(f"mutate.py: unknown mutant(s) {sorted(unknown)} in {a.list}")
        mutants = [m for m in mutants if m["name"] in want]
    log = build_dir / "mutate.log"
    log.write_text("")
    signal.signal(signal.SIGINT, on_signal)
    signal.signal(signal.SIGTERM, on_signal)

    # Every mutant must apply (its text exactly once) before anything is run.
    check_applies(mutants)

    t0 = time.time()
    if not a.no_baseline:
        targets = sorted({t for m in mutants for t in m["targets"].split()})
        print(f"mutate.py: baseline: building {' '.join(targets)} and running the named tests unmutated", flush=True)
        if not build(build_dir, targets, a.jobs, log):
            sys.exit(f"mutate.py: baseline build failed (see {log})")
        names = set()
        for m in mutants:
            found = test_names(build_dir, m["tests"])
            if not found:
                sys.exit(f"mutate.py: mutant {m['name']}: no test matches '{m['tests']}' in {build_dir}")
            names.update(found)
        for regex in exact_regexes(names):
            verdict, _ = ctest(build_dir, regex, a.timeout, log)
            if verdict != "pass":
                sys.exit(f"mutate.py: baseline tests do not pass unmutated ({verdict}; see {log})")
        print(f"mutate.py: baseline: {len(names)} tests pass unmutated ({time.time() - t0:.0f} s)", flush=True)

    results, touched = [], set()
    try:
        for m in mutants:
            path = ROOT / m["file"]
            original = path.read_bytes()
            text = original.decode()
            journal.write_text(json.dumps({"path": str(path), "original_hex": original.hex()}))
            t = time.time()
            try:
                path.write_text(text.replace(m["from"], m["to"], 1))
                touched.add((m["file"], m["targets"]))
                if not build(build_dir, m["targets"].split(), a.jobs, log):
                    verdict = "build-error"
                else:
                    verdict, out = ctest(build_dir, m["tests"], a.timeout, log)
            finally:
                path.write_bytes(original)
                journal.unlink(missing_ok=True)
            state = {"fail": "KILLED", "pass": "SURVIVED", "notests": "NO-TESTS", "build-error": "BUILD-ERROR"}[verdict]
            results.append((m["name"], state))
            print(f"{state:11s} {m['name']:32s} {time.time() - t:6.0f} s  ({m['file']})", flush=True)
    except Interrupted as e:
        print(f"mutate.py: interrupted ({e}); the file was restored", flush=True)
        return 2
    finally:
        # Leave the build folder consistent with the restored sources.
        for f, targets in sorted(touched):
            build(build_dir, targets.split(), a.jobs, log)

    survived = [n for n, s in results if s == "SURVIVED"]
    errors = [n for n, s in results if s in ("BUILD-ERROR", "NO-TESTS")]
    print(f"mutate.py: {sum(s == 'KILLED' for _, s in results)}/{len(results)} killed, "
          f"{len(survived)} survived {survived if survived else ''}, {len(errors)} errors {errors if errors else ''}; "
          f"{time.time() - t0:.0f} s (log: {log})", flush=True)
    if errors:
        return 2
    return 1 if survived else 0


if __name__ == "__main__":
    sys.exit(main())
