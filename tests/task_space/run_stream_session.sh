#!/usr/bin/env bash
# ctest driver of task_space.stream_session: a lockstep session over DDS (`hexa_session --stream
# --wait-for-operator`, own domain, own UDP port) driven as a user runs it: `hexa_operator
# stream`, hexa_stream_send's 100 Hz pose sine, the sender stopping (the supervisor's timeout and
# its return to neutral), bad packets (each counted by reason, never applied), `hexa_operator
# stop` (back to neutral, IDLE), then shutdown. Checked in supervisor.log and against the
# recording's ground truth (pose.csv): the stream moved the platform; it ended at neutral.
# The session is lockstep (its clock runs at the machine's pace, not the sender's), so the sine
# is not compared sample by sample here: the in-process tests do (supervisor_stream_test.cpp).
# Usage: run_stream_session.sh BUILD_DIR DOMAIN
set -euo pipefail
build="$1"; domain="$2"
port=$((47000 + domain))
out="$build/tests/task_space/stream_session"
rm -rf "$out"; mkdir -p "$out"
op="$build/services/task_space/hexa_operator"
send="$build/tools/hexa_stream_send"
. "$(dirname "$0")/operator_session_lib.sh"

"$build/deploy/hexa_session" --trajectory combined --periods 1 --seed 3 --domain "$domain" \
    --out "$out" --wait-for-operator --stream --stream-port "$port" --timeout 240 \
    > "$out/hexa_session.out" 2>&1 &
session=$!; pids+=("$session")
export HEXA_SESSION_KEY="$out/session.key"

for _ in $(seq 1 600); do
  grep -q 'rest pose' "$out/supervisor.log" 2>/dev/null && break
  kill -0 "$session" 2>/dev/null || { echo "FAIL: the session ended before the supervisor ran"; tail -20 "$out/hexa_session.out"; exit 1; }
  sleep 0.1
done
check "grep -q 'motion stream input ENABLED on UDP 127.0.0.1:$port' '$out/supervisor.log'" \
      "the supervisor listens on loopback, on the port asked"

run stream 0 stream
check "wait_log 'streaming from t = ' 1" "STREAMING from the neutral pose (supervisor.log)"
run stream_again 4 stream  # only from IDLE
"$send" --port "$port" --rate-hz 100 --duration-s 2 --motion sine --amplitude-m 0.02 \
    --frequency-hz 1 > "$out/send_sine.log" 2>&1
check "wait_log 'motion stream: packets applied from t' 1" "the packets were applied"
check "wait_log 'motion stream TIMEOUT at t = .* no packet for' 1" "the sender's stop raised the timeout"
check "wait_log 'motion stream: at neutral at t' 1" "the platform returned to neutral, still streaming"
# Bad packets only (every other one bad: wrong size, version, NaN, absurd value in turn).
"$send" --port "$port" --rate-hz 100 --duration-s 0.4 --bad-every 1 --amplitude-m 0.0 \
    --first-sequence 1 > "$out/send_bad.log" 2>&1
sleep 1
run stop_streaming 0 stop
check "wait_log 'stream stopped: at neutral at t' 1" "stop: at neutral, IDLE"
check "wait_log 'motion stream so far: applied [1-9]' 1" "the counters are logged"
grep -E "motion stream|stream stopped|streaming from" "$out/supervisor.log" || true
counters=$(grep -oE 'refused by the decoder: wrong size [0-9]+, bad magic [0-9]+, wrong version [0-9]+, unknown kind [0-9]+, not finite [0-9]+, absurd value [0-9]+' "$out/supervisor.log" | tail -1)
check "echo '$counters' | grep -qE 'wrong size [1-9].*wrong version [1-9].*not finite [1-9].*absurd value [1-9]'" \
      "bad packets counted by reason ($counters)"
sleep 1
"$op" --domain "$domain" --wait 30 shutdown > "$out/op_shutdown.log" 2>&1 || true
rc=0; wait "$session" || rc=$?
# A stream is not the session's trajectory: the shutdown ends it before the trajectory started.
check "[ $rc -eq 6 ]" "hexa_session ends 6 after the shutdown, the trajectory never started (got $rc)"
check "grep -q 'session did NOT complete (exit 6): shut down by the operator before the trajectory started (operator motions only: stream)' '$out/hexa_session.out'" \
      "the console says the operator shut the session down before the trajectory, after a stream"

/usr/bin/python3 - "$out" <<'EOF' || fail=1
import csv, re, sys
out = sys.argv[1]
log = open(out + "/supervisor.log").read()
rows = [list(map(float, r)) for r in list(csv.reader(open(out + "/pose.csv")))[1:]]
DES, TRUE = 1, 7
t0 = float(re.search(r"streaming from t = ([0-9.]+) s", log).group(1))
t_end = float(re.search(r"stream stopped: at neutral at t = ([0-9.]+) s", log).group(1))
def at(ts, col):
    for r in rows:
        if r[0] >= ts - 1e-9: return r[col:col + 6]
    return rows[-1][col:col + 6]
neutral_des, neutral_true = at(t0, DES), at(t0, TRUE)
span = [r for r in rows if t0 <= r[0] <= t_end]
peak_des = max(abs(r[DES] - neutral_des[0]) for r in span)
peak_true = max(abs(r[TRUE] - neutral_true[0]) for r in span)
end_des = at(t_end, DES)
back = max(abs(end_des[k] - neutral_des[k]) for k in range(6))
ok = peak_des > 0.01 and peak_true > 0.01 and back < 1e-4
print(f"stream: setpoint x moved up to {peak_des*1e3:.2f} mm from neutral (stream amplitude 20 mm), "
      f"platform {peak_true*1e3:.2f} mm; at the stop's end {back*1e3:.4f} mm / mrad from neutral")
print(("ok: " if ok else "FAIL: ") + "the stream moved the platform and the stop ended at neutral")
sys.exit(0 if ok else 1)
EOF
echo "stream_session: $([ $fail -eq 0 ] && echo PASSED || echo FAILED)"
exit $fail
