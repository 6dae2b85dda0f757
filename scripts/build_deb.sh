#!/usr/bin/env bash
# Builds the Debian package hexataar-control (CPack DEB) in ./build-deb: a build with
# HEXA_PACKAGE_LAYOUT=ON (defaults point at /usr/share/hexa and /etc/hexa), no tests or
# benchmarks, and the same compiler flags as ./scripts/build.sh (RelWithDebInfo; the package's
# binaries are stripped), so that with ccache (CMAKE_CXX_COMPILER_LAUNCHER=ccache) every object
# the developer build already compiled is a cache hit. Then runs lintian on it when lintian is
# installed. Build output goes to build-deb/build.log; prints one line per stage and the .deb's
# path. What the package installs where: docs/deployment.md, "Debian package".
# Usage: scripts/build_deb.sh [--no-lintian]
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
build_dir="${HEXA_DEB_BUILD_DIR:-$here/build-deb}"
mkdir -p "$build_dir"
log="$build_dir/build.log"
: > "$log"
stage() {  # stage NAME COMMAND...: one line, the command's output to the log
  local t0=$SECONDS
  printf 'build_deb: %s ... ' "$1"
  shift
  if "$@" >>"$log" 2>&1; then
    echo "done ($((SECONDS - t0)) s)"
  else
    echo "FAILED; the last lines of $log:"
    tail -n 30 "$log"
    exit 1
  fi
}
if command -v ccache >/dev/null && [ -z "${CMAKE_CXX_COMPILER_LAUNCHER:-}" ]; then
  export CMAKE_C_COMPILER_LAUNCHER=ccache CMAKE_CXX_COMPILER_LAUNCHER=ccache
  export CCACHE_BASEDIR="${CCACHE_BASEDIR:-$here}"
fi
stage configure cmake -S "$here" -B "$build_dir" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DHEXA_PACKAGE_LAYOUT=ON -DHEXA_BUILD_TESTS=OFF -DHEXA_BUILD_BENCH=OFF -DCMAKE_INSTALL_PREFIX=/usr
stage "compile (-j ${HEXA_JOBS:-2})" cmake --build "$build_dir" -j "${HEXA_JOBS:-2}"
rm -f "$build_dir"/hexataar-control_*.deb
stage package bash -c "cd '$build_dir' && cpack -G DEB"
deb="$(ls -t "$build_dir"/hexataar-control_*.deb | head -n 1)"
echo "build_deb: $deb"
if [ "${1:-}" != "--no-lintian" ] && command -v lintian >/dev/null; then
  # The remaining tags are explained in docs/deployment.md ("Debian package").
  lintian --info --no-tag-display-limit "$deb" || true
fi
