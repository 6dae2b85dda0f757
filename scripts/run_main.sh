#!/usr/bin/env bash
# The main job on a fresh Debian 12 machine: install, build, run one complete closed-loop
# session (plant, six leg controllers, supervisor, recorder over loopback DDS) with the
# defaults (combined trajectory, BS-SMC, realistic profile, lockstep) and write the report.
# Extra arguments go to hexa_session (see: build/deploy/hexa_session --help).
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
"$here/scripts/install_deps.sh"
"$here/scripts/build.sh"
build_dir="${HEXA_BUILD_DIR:-$here/build}"
export CYCLONEDDS_URI="${CYCLONEDDS_URI:-file://$here/deploy/cyclonedds-loopback.xml}"
exec "$build_dir/deploy/hexa_session" --out "$here/out/session-$(date +%Y%m%d-%H%M%S)" "$@"
