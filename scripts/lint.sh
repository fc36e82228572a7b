#!/usr/bin/env bash
# Formatting and naming checks (issue 17; STYLE.md §3).
# Usage:
#   scripts/lint.sh                 check that no C++ file is over 600 lines (STYLE.md), then every
#                                   C++ file against .clang-format (fails on the first unformatted
#                                   file, naming it), and that every mutant of tests/mutants.txt
#                                   still applies; a few seconds, run by scripts/test.sh
#   scripts/lint.sh --fix           apply .clang-format to every C++ file in place
#   scripts/lint.sh --tidy [FILES]  clang-tidy (.clang-tidy: the naming rules) on FILES, default all
#                                   .cpp files; needs build/compile_commands.json; ~10 s per file
set -euo pipefail
cd "$(dirname "$0")/.."

mapfile -t files < <(git ls-files -- '*.cpp' '*.hpp' | grep -E '^(core|constraints|imaging|data_synth|apps|tests|bench)/')

case "${1:-}" in
  --fix)
    clang-format -i --style=file "${files[@]}"
    echo "lint: formatted ${#files[@]} files"
    ;;
  --tidy)
    shift
    if [ ! -f build/compile_commands.json ]; then
      echo "lint: build/compile_commands.json is missing: run scripts/build.sh first" >&2
      exit 1
    fi
    if [ $# -gt 0 ]; then targets=("$@"); else mapfile -t targets < <(printf '%s\n' "${files[@]}" | grep '\.cpp$'); fi
    clang-tidy -p build --quiet "${targets[@]}"
    ;;
  "")
    # No C++ source file over max_lines lines (STYLE.md; issue 17): split it by responsibility.
    max_lines=600
    too_long=$(git ls-files -- '*.cpp' '*.hpp' | xargs wc -l | awk -v m="$max_lines" '$2 != "total" && $1 > m {print $2 " (" $1 " lines)"}')
    if [ -n "$too_long" ]; then
      while IFS= read -r f; do
        echo "lint: $f is over $max_lines lines; split it (STYLE.md: files <= $max_lines lines)" >&2
      done <<<"$too_long"
      exit 1
    fi
    # One clang-format process for all files; its warnings name each unformatted file.
    if ! out=$(clang-format --style=file --dry-run -Werror "${files[@]}" 2>&1); then
      mapfile -t bad < <(printf '%s\n' "$out" | grep -oE '^[^:]+\.(cpp|hpp):' | sort -u | tr -d ':')
      echo "lint: ${#bad[@]} of ${#files[@]} C++ files are not formatted per .clang-format, first: ${bad[0]:-?}" >&2
      echo "lint: run scripts/lint.sh --fix (clang-format $(clang-format --version | grep -o '[0-9][0-9.]*' | head -1))" >&2
      exit 1
    fi
    echo "lint: ${#files[@]} C++ files formatted per .clang-format"
    # The mutation check's mutants must still apply after a reformat or an edit (issue 19).
    python3 scripts/mutate.py --check
    ;;
  *)
    echo "lint: unknown argument '$1' (use --fix or --tidy [FILES])" >&2
    exit 1
    ;;
esac
