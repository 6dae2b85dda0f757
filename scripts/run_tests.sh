#!/usr/bin/env bash
# The whole test suite on a fresh Debian 12 machine: install, build, ctest.
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
"$here/scripts/install_deps.sh"
"$here/scripts/build.sh"
cd "${HEXA_BUILD_DIR:-$here/build}"
ctest --output-on-failure -j 2 --timeout 600
