#!/usr/bin/env bash
# ctest driver of foxglove.bridge_live: a session with `hexa_session --bridge` (40 periods: the
# lockstep loop runs at ~3x real time, and the stuck client must outlive a 5 s stats period; own domain, the
# bridge on a free port, 256 KiB per-client queue), a client that never reads (stuck_client.py)
# subscribed to every channel for the whole session, and Foxglove's own client library
# (js/check_bridge.mjs): decode 1000 LegSensors and the scene, unsubscribe, bad clients closed.
# Then: the session completed (exit 0, report written), the bridge counted drops for the stuck
# client and none for the others, and logged the protocol errors.
# Usage: run_bridge_test.sh SRC_DIR NODE_DIR BUILD_DIR DOMAIN
set -euo pipefail
src="$1"; node_dir="$2"; build="$3"; domain="$4"
out="$build/tests/foxglove/bridge_session"
rm -rf "$out"; mkdir -p "$out"
pids=()
cleanup() { for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done; wait 2>/dev/null || true; }
trap cleanup EXIT

"$build/deploy/hexa_session" --trajectory combined --periods 40 --seed 3 --domain "$domain" \
    --out "$out" --bridge --bridge-port 0 --bridge-queue-kb 256 > "$out/hexa_session.out" 2>&1 &
session=$!; pids+=("$session")
port=""
for _ in $(seq 1 300); do
  port=$(grep -oE 'on ws://127\.0\.0\.1:[0-9]+' "$out/bridge.log" 2>/dev/null | head -1 | sed 's/.*://') || true
  [ -n "$port" ] && break
  kill -0 "$session" 2>/dev/null || { echo "FAIL: the session ended before the bridge served"; cat "$out/hexa_session.out"; exit 1; }
  sleep 0.1
done
[ -n "$port" ] || { echo "FAIL: the bridge did not start (bridge.log)"; cat "$out/bridge.log" || true; exit 1; }
echo "bridge on port $port"
/usr/bin/python3 "$src/stuck_client.py" "$port" > "$out/stuck_client.out" 2>&1 &
stuck=$!; pids+=("$stuck")
for _ in $(seq 1 100); do grep -q subscribed "$out/stuck_client.out" 2>/dev/null && break; sleep 0.1; done
cat "$out/stuck_client.out"
fail=0
(cd "$node_dir" && node check_bridge.mjs "ws://127.0.0.1:$port") || fail=1
rc=0
wait "$session" || rc=$?
kill "$stuck" 2>/dev/null || true
echo "hexa_session exit status $rc"
[ "$rc" -eq 0 ] || { echo "FAIL: the session did not complete"; tail -20 "$out/hexa_session.out"; fail=1; }
[ -f "$out/report.md" ] || { echo "FAIL: no report.md"; fail=1; }
# The bridge's own accounting (bridge.log): per client at close or in the periodic stats.
grep -E "client [0-9]+ .*(closed|failed|dropped)" "$out/bridge.log" | tail -12 || true
stuck_drops=$(grep -oE 'client 1 \([^)]*\)[^,]*, sent [0-9]+ messages \([0-9]+ bytes\), dropped [0-9]+' "$out/bridge.log" \
              | tail -1 | grep -oE '[0-9]+$' || echo 0)
echo "stuck client (client 1): dropped $stuck_drops"
[ "${stuck_drops:-0}" -gt 0 ] || { echo "FAIL: no drops counted for the client that never reads"; fail=1; }
other_drops=$(grep -E 'client ([2-9]|[1-9][0-9]+) \(' "$out/bridge.log" | grep -oE 'dropped [0-9]+' \
               | grep -vc 'dropped 0$' || true)
echo "reading clients with drops: $other_drops"
[ "$other_drops" -eq 0 ] || { echo "FAIL: a reading client had drops"; fail=1; }
perrs=$(grep -c "protocol error" "$out/bridge.log" || true)
echo "protocol errors logged: $perrs"
echo "bridge_live: $([ $fail -eq 0 ] && echo PASSED || echo FAILED)"
[ "$perrs" -ge 4 ] || { echo "FAIL: expected 4 protocol errors in bridge.log"; fail=1; }
exit $fail
