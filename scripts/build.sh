#!/usr/bin/env bash
# Configures and builds into ./build (RelWithDebInfo, -j2 on this 2-core machine).
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
build_dir="${HEXA_BUILD_DIR:-$here/build}"
# ccache lets the package build (scripts/build_deb.sh, run by tests/package) reuse these objects.
if command -v ccache >/dev/null && [ -z "${CMAKE_CXX_COMPILER_LAUNCHER:-}" ]; then
  export CMAKE_C_COMPILER_LAUNCHER=ccache CMAKE_CXX_COMPILER_LAUNCHER=ccache
  export CCACHE_BASEDIR="${CCACHE_BASEDIR:-$here}"
fi
cmake -S "$here" -B "$build_dir" -DCMAKE_BUILD_TYPE=RelWithDebInfo
cmake --build "$build_dir" -j "${HEXA_JOBS:-2}"
