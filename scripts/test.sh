#!/usr/bin/env bash
# Installs dependencies, builds brainshift and runs every test through CTest.
# Usage: scripts/test.sh [ctest args, e.g. -L core]
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/build.sh
ctest --test-dir build --output-on-failure -j "${BS_JOBS:-$(nproc)}" "$@"
