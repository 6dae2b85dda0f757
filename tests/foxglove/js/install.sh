#!/usr/bin/env bash
# Installs the test clients (package-lock.json pins them) into the build tree, with the check
# scripts. Skips (77) only when npm cannot reach the registry and its cache lacks a package.
# --prefer-offline: a package already in npm's cache (checked against the lock's integrity hash)
# is not revalidated with the registry; with the registry unreachable, npm ci spent ~150 s in
# fetch retries before it fell back to that cache.
set -euo pipefail
src="$1"; dir="$2"
mkdir -p "$dir"
cp "$src"/package.json "$src"/package-lock.json "$src"/*.mjs "$dir/"
cd "$dir"
if ! cmp -s package-lock.json node_modules/.hexa-lock 2>/dev/null; then
  if ! timeout 600 npm ci --prefer-offline --no-audit --no-fund --loglevel=error >npm.log 2>&1; then
    if grep -qiE "ENOTFOUND|EAI_AGAIN|ECONNREFUSED|ETIMEDOUT|ENETUNREACH|network" npm.log; then
      echo "SKIP: npm cannot reach the registry (see $dir/npm.log)"
      exit 77
    fi
    cat npm.log
    exit 1
  fi
  cp package-lock.json node_modules/.hexa-lock
fi
echo "test clients installed in $dir"
