#!/usr/bin/env bash
# Configures and builds brainshift (Release by default) into build/.
# Usage: scripts/build.sh [extra cmake args]
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install_deps.sh
BUILD_TYPE="${BS_BUILD_TYPE:-Release}"
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE="$BUILD_TYPE" "$@"
cmake --build build -j "${BS_JOBS:-$(nproc)}"
