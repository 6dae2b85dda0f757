#!/usr/bin/env bash
# Builds the Debian package hexataar-control (CPack DEB) in ./build-deb: a Release build with
# HEXA_PACKAGE_LAYOUT=ON (defaults point at /usr/share/hexa and /etc/hexa), no tests or
# benchmarks. Then runs lintian on it when lintian is installed. Prints the .deb's path.
# Usage: scripts/build_deb.sh [--no-lintian]
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
build_dir="${HEXA_DEB_BUILD_DIR:-$here/build-deb}"
cmake -S "$here" -B "$build_dir" -DCMAKE_BUILD_TYPE=Release -DHEXA_PACKAGE_LAYOUT=ON \
  -DHEXA_BUILD_TESTS=OFF -DHEXA_BUILD_BENCH=OFF -DCMAKE_INSTALL_PREFIX=/usr >/dev/null
cmake --build "$build_dir" -j "${HEXA_JOBS:-2}"
(cd "$build_dir" && cpack -G DEB >/dev/null)
deb="$(ls -t "$build_dir"/hexataar-control_*.deb | head -n 1)"
echo "build_deb: $deb"
if [ "${1:-}" != "--no-lintian" ] && command -v lintian >/dev/null; then
  # The remaining tags are explained in docs/deployment.md ("Debian package").
  lintian --info --no-tag-display-limit "$deb" || true
fi
