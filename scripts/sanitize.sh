#!/usr/bin/env bash
# AddressSanitizer + UndefinedBehaviorSanitizer run of the unit tests (CTest label `unit`), on
# demand (not a CI step: it is a separate, slower build). Configures build-asan/ (RelWithDebInfo
# at -O1, with assertions: Eigen's index checks are on), builds only the executables that carry
# the label, and runs `ctest -L <label>` there, one test folder (module) at a time. Any sanitizer
# report fails the test that made it (halt_on_error / -fno-sanitize-recover).
#
# Usage: scripts/sanitize.sh [ctest label regex, default "unit"] [executable ...]
#   scripts/sanitize.sh                              # every unit executable
#   scripts/sanitize.sh unit test_core test_data_synth   # a subset of the executables
# Environment: BS_ASAN_DIR (build folder, default build-asan), BS_JOBS (default 1) and BS_NICE
# (default 10): the build and the tests are niced and serial so that they can run on a shared machine
# (on a loaded one nice 10 starves them: BS_NICE=0 there, still -j1).
set -euo pipefail
cd "$(dirname "$0")/.."
label="${1:-unit}"
shift || true
build="${BS_ASAN_DIR:-build-asan}"
jobs="${BS_JOBS:-1}"
niceness="${BS_NICE:-10}"

# The test executables carrying the label, from their bs_add_test(...) registrations.
if [ "$#" -gt 0 ]; then
  targets=("$@")
else
  mapfile -t targets < <(grep -ho 'bs_add_test([A-Za-z0-9_]* LABEL "[^"]*"' tests/*/CMakeLists.txt |
    awk -v l="$label" '{ gsub(/"/, "", $3); n = split($3, ls, ";"); for (i = 1; i <= n; ++i)
      if (ls[i] ~ "^(" l ")$") { sub(/bs_add_test\(/, "", $1); print $1; break } }')
fi
[ "${#targets[@]}" -gt 0 ] || { echo "sanitize.sh: no test executable has label '$label'" >&2; exit 2; }

flags="-fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=all"
launcher=()
command -v ccache > /dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
# One cache for the main checkout and its worktrees: paths under the folder that holds the main
# checkout are rewritten relative (the default when CCACHE_BASEDIR is unset).
common="$(git rev-parse --path-format=absolute --git-common-dir 2> /dev/null || echo "$PWD/.git")"
export CCACHE_BASEDIR="${CCACHE_BASEDIR:-$(dirname "$(dirname "$common")")}"
# With -g, ccache hashes the working directory too (hash_dir), so without this every worktree
# missed the others' objects. The price: a cached object's debug info names the build folder that
# compiled it first (reports still give the right source file and line).
export CCACHE_NOHASHDIR="${CCACHE_NOHASHDIR:-1}"
cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1" -DCMAKE_CXX_FLAGS="$flags" \
  -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=address,undefined" \
  -DCMAKE_SHARED_LINKER_FLAGS="-fsanitize=address,undefined" \
  -DBS_BUILD_BENCH=OFF -DBS_TEST_TIMEOUT_SCALE=10 "${launcher[@]}"

# Test discovery runs the executables at build time: the same options apply there.
# Leak checking stays on; tests/sanitize/lsan.supp names leaks of system libraries we do not own.
export ASAN_OPTIONS="detect_leaks=1:abort_on_error=0:halt_on_error=1:strict_string_checks=1:detect_stack_use_after_return=1"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
export LSAN_OPTIONS="suppressions=$PWD/tests/sanitize/lsan.supp:print_suppressions=0"
# One test folder (module) at a time: build its executables, then run their tests, so that a
# finding shows up as soon as its module is built and an interrupted run has still tested the
# modules before it (the four libraries come first, with the first module). Executables of the
# label that were not built register a <name>_NOT_BUILT placeholder test: leave those out.
module_of() { basename "$(dirname "$(grep -l "bs_add_test($1 " tests/*/CMakeLists.txt | head -n 1)")"; }
mapfile -t modules < <(for t in "${targets[@]}"; do module_of "$t"; done | awk '!seen[$0]++')
status=0
for module in "${modules[@]}"; do
  module_targets=()
  for t in "${targets[@]}"; do [ "$(module_of "$t")" = "$module" ] && module_targets+=("$t"); done
  echo "sanitize.sh: building ${module_targets[*]}"
  nice -n "$niceness" cmake --build "$build" -j "$jobs" --target "${module_targets[@]}"
  nice -n "$niceness" ctest --test-dir "$build/tests/$module" -L "$label" -E '_NOT_BUILT' \
    -j "$jobs" --output-on-failure || status=1
done
exit "$status"
