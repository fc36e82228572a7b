#!/usr/bin/env bash
# Installs dependencies, builds brainshift and runs the main job on built-in data.
# Usage: scripts/demo.sh [--out DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/build.sh
exec build/apps/brainshift demo "$@"
