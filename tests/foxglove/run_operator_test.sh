#!/usr/bin/env bash
# ctest driver of foxglove.operator_input: `hexa_session --wait-for-operator --bridge
# --bridge-operator-input` (lockstep, combined trajectory 40 periods: the stop ends it, own domain, bridge on a
# free port), then js/check_operator.mjs drives it with Foxglove's client library: bad inputs
# refused, the rate limit, jogs in two frames, a pose goal, a goal outside the soft limits
# refused, a pivot change (bad ones refused by the bridge or the supervisor) and a roll about the
# new pivot, start and stop seen in the supervisor's state. Then: the session
# ended by itself after the stop (exit 6: stopped by the operator, docs/exit_codes.md), the supervisor logged both commands from the
# bridge, and the bridge logged what it wrote and what it refused; and, on the recording's ground
# truth (tests/support/operator_truth.py), the jog let go was at rest within the dead-man time plus
# the braking time and distance, the goal was reached, and the roll about the new pivot kept
# that point still within 5 mm while the platform origin moved.
# Usage: run_operator_test.sh SRC_DIR NODE_DIR BUILD_DIR DOMAIN
set -euo pipefail
src="$1"; node_dir="$2"; build="$3"; domain="$4"
out="$build/tests/foxglove/operator_session"
rm -rf "$out"; mkdir -p "$out"
pids=()
cleanup() { for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done; wait 2>/dev/null || true; }
trap cleanup EXIT

"$build/deploy/hexa_session" --trajectory combined --periods 40 --seed 3 --domain "$domain" \
    --out "$out" --wait-for-operator --bridge --bridge-port 0 --bridge-operator-input \
    --timeout 240 > "$out/hexa_session.out" 2>&1 &
session=$!; pids+=("$session")
port=""
for _ in $(seq 1 300); do
  port=$(grep -oE 'on ws://127\.0\.0\.1:[0-9]+' "$out/bridge.log" 2>/dev/null | head -1 | sed 's/.*://') || true
  [ -n "$port" ] && break
  kill -0 "$session" 2>/dev/null || { echo "FAIL: the session ended before the bridge served"; cat "$out/hexa_session.out"; exit 1; }
  sleep 0.1
done
[ -n "$port" ] || { echo "FAIL: the bridge did not start (bridge.log)"; exit 1; }
fail=0
(cd "$node_dir" && node check_operator.mjs "ws://127.0.0.1:$port") || fail=1
rc=0
wait "$session" || rc=$?
echo "hexa_session exit status $rc"
[ "$rc" -eq 6 ] || { echo "FAIL: the session did not end as stopped by the operator (exit 6) after the stop"; tail -5 "$out/hexa_session.out"; fail=1; }
grep -q "stopped by the operator" "$out/hexa_session.out" ||
  { echo "FAIL: the console does not say the operator stopped the session"; fail=1; }
grep -E "operator command #[0-9]+ (start|stop)" "$out/bridge.log" || true
grep -E "operator command #[0-9]+: kind" "$out/supervisor.log" | head -3 || true
grep -qE "operator command #[0-9]+ start combined written" "$out/bridge.log" || { echo "FAIL: the bridge wrote no start"; fail=1; }
[ "$(grep -cE "operator command #[0-9]+: kind 0 trajectory 'combined'" "$out/supervisor.log")" -eq 1 ] \
  || { echo "FAIL: the supervisor did not get exactly one start"; fail=1; }
grep -q "goal refused: the goal leaves the pose box" "$out/supervisor.log" ||
  { echo "FAIL: the supervisor did not log why it refused the goal outside the soft limits"; fail=1; }
grep -E "jogging from|jog at rest|goal motion at rest" "$out/supervisor.log" || { echo "FAIL: no jog or goal in supervisor.log"; fail=1; }
grep -q "frames refused: frames.p_PC_P_m: pivot point (from the platform origin) is too far away (value 0.8 m, limit <= 0.5 m)" \
  "$out/supervisor.log" || { echo "FAIL: the supervisor did not log why it refused the pivot 0.8 m away"; fail=1; }
grep -q "operator input refused: operator input: pivot_m (10, 0, 0) is 10 m from the platform origin: absurd (limit 2 m)" \
  "$out/bridge.log" || { echo "FAIL: the bridge did not log why it refused the pivot 10 m away"; fail=1; }
grep -E "frames set at t" "$out/supervisor.log" || { echo "FAIL: the supervisor did not log the pivot it took"; fail=1; }
refusals=$(grep -c "operator input refused\|not accepted\|rate limit" "$out/bridge.log" || true)
echo "refusals logged by the bridge: $refusals"
[ "$refusals" -ge 10 ] || { echo "FAIL: expected the refusals in bridge.log"; fail=1; }
# Ground truth (the recording's pose.csv): the first jog (+x at 3 cm/s, work frame) let go, at
# rest within the dead-man time plus the braking; the goal reached; the roll about the pivot
# (0, 0.05, 0.2) m set from the client kept that point still.
/usr/bin/python3 "$src/../support/operator_truth.py" "$out" 0.03 0,0.05,0.2 || fail=1
echo "operator_input: $([ $fail -eq 0 ] && echo PASSED || echo FAILED)"
exit $fail
