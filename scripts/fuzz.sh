#!/usr/bin/env bash
# Fuzzes each reader of hostile input (tests/fuzz) with clang's libFuzzer under ASan + UBSan.
# Usage: scripts/fuzz.sh [SECONDS_PER_TARGET (default 60)] [TARGET...]
#   targets: nrrd landmarks plus_sequence nifti_header igtl_image volume vtk_xml scene
#            model_manifest compliance_cache (default: all)
# Builds into build-fuzz/ (clang, -DBS_FUZZ=ON, RelWithDebInfo), runs each target from its seed
# corpus (tests/fuzz/corpus/<target>, copied to build-fuzz/corpus/<target> where the fuzzer adds
# what it finds), copies any crash to tests/fuzz/crashes/<target>/ (a regression input for CTest),
# and prints executions, coverage and crashes per target. Exit 1 when a target crashed.
# An allocation beyond what the allocator can give (> 1 TiB) fails as it does in production (VTK's
# readers then throw std::bad_alloc, a one-line error). A single allocation up to 64 GiB is not a
# finding by itself (VTK reserves what a corrupt offsets array claims, then finds the data short,
# touching none of it); resident memory beyond 2 GiB is (-rss_limit_mb).
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-60}"
shift || true
targets=("$@")
[ ${#targets[@]} -eq 0 ] && targets=(nrrd landmarks plus_sequence nifti_header igtl_image volume vtk_xml
                                      scene model_manifest compliance_cache)
scripts/install_deps.sh
CC=clang CXX=clang++ cmake -S . -B build-fuzz -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DBS_FUZZ=ON -DBS_BUILD_TESTS=OFF -DBS_BUILD_APPS=ON -DBS_BUILD_BENCH=OFF >/dev/null
cmake --build build-fuzz -j "${BS_JOBS:-$(nproc)}" --target "${targets[@]/#/fuzz_}"
export ASAN_OPTIONS=detect_leaks=0:abort_on_error=1:allocator_may_return_null=1 UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1
failed=0
for t in "${targets[@]}"; do
  corpus=build-fuzz/corpus/$t crashes=build-fuzz/crashes/$t
  mkdir -p "$corpus" "$crashes"
  cp -n tests/fuzz/corpus/"$t"/* "$corpus"/ 2>/dev/null || true
  log=build-fuzz/fuzz_$t.log
  if build-fuzz/tests/fuzz/fuzz_"$t" -max_total_time="$seconds" -rss_limit_mb=2048 -malloc_limit_mb=65536 -timeout=10 \
      -artifact_prefix="$crashes"/ "$corpus" >"$log" 2>&1; then status=clean; else status=CRASH; failed=1; fi
  stats=$(grep -E "^#[0-9]+.*(DONE|pulse|NEW)" "$log" | tail -1 | sed -E 's/^#([0-9]+)\s+\w+\s+cov: ([0-9]+) ft: ([0-9]+).*/\1 executions, coverage \2 edges (\3 features)/')
  if [ "$status" = clean ]; then
    echo "fuzz $t: clean for ${seconds} s: $stats"
  else
    echo "fuzz $t: CRASH (libFuzzer stops at the first): $stats before it"
  fi
  if [ "$status" = CRASH ]; then
    mkdir -p tests/fuzz/crashes/"$t"
    cp "$crashes"/* tests/fuzz/crashes/"$t"/ 2>/dev/null || true
    grep -E "ERROR|SUMMARY|runtime error" "$log" | head -5
  fi
done
exit $failed
