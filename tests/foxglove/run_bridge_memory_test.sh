#!/usr/bin/env bash
# ctest driver of foxglove.bridge_memory: the 1 kHz topics of a real-time session
# (bridge_load_source: 13 samples a millisecond) and hexa_bridge on the same domain
# (--max-clients 200, the default queues), then
# js/bridge_memory.mjs: 100 clients reading every channel and 100 that stop reading, 5 more
# refused with HTTP 503, the bridge's resident set under idle + 128 MiB (--total-queue-mb) +
# 0.25 MiB per client while they stay, and back within 25 % of its idle figure after they leave
# (10 % is printed). Then, from the bridge's log: the refusals, and the bytes its allocator
# holds for live objects after they left within 0.5 MiB of the figure after the warm-up client
# (nothing kept: what the resident set keeps beyond is free memory on pinned pages).
# Usage: run_bridge_memory_test.sh SRC_DIR NODE_DIR BUILD_DIR DOMAIN LOAD_SOURCE
set -euo pipefail
src="$1"; node_dir="$2"; build="$3"; domain="$4"; source_exe="$5"
out="$build/tests/foxglove/bridge_memory"
rm -rf "$out"; mkdir -p "$out"
pids=()
cleanup() { for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done; wait 2>/dev/null || true; }
trap cleanup EXIT

"$source_exe" --domain "$domain" --seconds 120 > "$out/source.out" 2>&1 &
pids+=($!)
"$build/services/bridge/hexa_bridge" --domain "$domain" --port 0 --max-clients 200 --total-queue-mb 128 \
    --stats-s 5 --log-file "$out/bridge.log" > "$out/bridge.console.log" 2>&1 &
bridge=$!; pids+=("$bridge")
port=""
for _ in $(seq 1 300); do
  port=$(grep -oE 'on ws://127\.0\.0\.1:[0-9]+' "$out/bridge.log" 2>/dev/null | head -1 | sed 's/.*://') || true
  [ -n "$port" ] && break
  kill -0 "$bridge" 2>/dev/null || { echo "FAIL: the bridge exited"; cat "$out/bridge.console.log"; exit 1; }
  sleep 0.1
done
[ -n "$port" ] || { echo "FAIL: the bridge did not start (bridge.log)"; exit 1; }
fail=0
(cd "$node_dir" && node bridge_memory.mjs "ws://127.0.0.1:$port" "$bridge" 100 100 5 15 128 0.25) || fail=1
kill -0 "$bridge" 2>/dev/null || { echo "FAIL: the bridge died"; fail=1; }
refused=$(grep -c "refused a connection" "$out/bridge.log" || true)
echo "refusals logged: $refused"
[ "$refused" -ge 5 ] || { echo "FAIL: expected 5 refused connections in bridge.log"; fail=1; }
grep -E "clients, [0-9]+ bytes queued for all" "$out/bridge.log" | tail -1 || true
grep "freed memory returned" "$out/bridge.log" || true
allocated=$(grep -oE "[0-9.]+ MiB allocated" "$out/bridge.log" | sed 's/ MiB.*//' || true)
warm=$(echo "$allocated" | head -1); last=$(echo "$allocated" | tail -1)
echo "allocated after the warm-up client: ${warm:-?} MiB, after every client left: ${last:-?} MiB"
if [ -z "$warm" ] || ! awk -v w="$warm" -v l="$last" 'BEGIN { exit !(l <= w + 0.5) }'; then
  echo "FAIL: the allocator holds more after the clients left"; fail=1
fi
echo "bridge_memory: $([ $fail -eq 0 ] && echo PASSED || echo FAILED)"
exit $fail
