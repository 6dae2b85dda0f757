#!/usr/bin/env bash
# Configures and builds into ./build (RelWithDebInfo, -j2 on this 2-core machine).
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
build_dir="${HEXA_BUILD_DIR:-$here/build}"
cmake -S "$here" -B "$build_dir" -DCMAKE_BUILD_TYPE=RelWithDebInfo
cmake --build "$build_dir" -j "${HEXA_JOBS:-2}"
