#!/usr/bin/env bash
# ctest driver of the independent-reader test: installs @mcap/core and protobufjs from the npm
# registry (pinned by package-lock.json) into the build tree, writes the synthetic recording,
# and a recovered copy of a truncated one, and checks both with check_mcap.mjs.
# Skips (exit 77) only when npm cannot reach the registry and its cache lacks a package.
# --prefer-offline: cached packages (checked against the lock's integrity hashes) are not
# revalidated with the registry (tests/foxglove/js/install.sh says why).
set -euo pipefail
src_dir="$1"; work_dir="$2"; synth_bin="$3"; recorder_bin="$4"
mkdir -p "$work_dir"
cp "$src_dir/package.json" "$src_dir/package-lock.json" "$src_dir/check_mcap.mjs" "$work_dir/"
cd "$work_dir"
if ! cmp -s package-lock.json node_modules/.hexa-lock 2>/dev/null; then
  if ! timeout 600 npm ci --prefer-offline --no-audit --no-fund --loglevel=error >npm.log 2>&1; then
    if grep -qiE "ENOTFOUND|EAI_AGAIN|ECONNREFUSED|ETIMEDOUT|ENETUNREACH|network" npm.log; then
      echo "SKIP: npm cannot reach the registry (see $work_dir/npm.log)"
      exit 77
    fi
    cat npm.log
    echo "npm ci failed"
    exit 1
  fi
  cp package-lock.json node_modules/.hexa-lock
fi
# Uncompressed chunks here (this package set has no zstd decompressor); the compressed files
# are read with @mcap/support's decompressors in tests/foxglove (foxglove.session_js).
"$synth_bin" synth.mcap none
echo "== synthetic recording"
node check_mcap.mjs synth.mcap "$recorder_bin"
# A recording cut mid-file (as after kill -9), then recovered: the result must be a valid MCAP
# file for the independent reader too.
head -c 1000000 synth.mcap > truncated.mcap
"$recorder_bin" recover truncated.mcap --output recovered.mcap --compression none
echo "== recovered recording"
node check_mcap.mjs recovered.mcap "$recorder_bin"
