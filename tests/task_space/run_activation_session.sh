#!/usr/bin/env bash
# ctest driver of task_space.activation_session: the hardware lifecycle in lockstep sessions over
# DDS (`hexa_session --activation operator`, own domain), driven with hexa_operator as a user runs
# it (docs/faults.md, "Hardware lifecycle").
#   1. estop, then start: refused (exit 4) naming the e-stop; reset, then start: the activation
#      is granted and the trajectory completes (session exit 0). Ground truth: every valve at its
#      null (5 V) from tick 0 up to the activation's tick, the valves moving after it.
#   2. the supply lost at t = 0: start refused, naming the supply pressure.
#   3. leg 2's cap-pressure sensor dead at t = 0: start refused, naming the sensor, leg and value.
#   4. leg 3's controller crashed at t = 0.1 s: start refused, naming the leg without a controller.
# Usage: run_activation_session.sh BUILD_DIR DOMAIN
set -euo pipefail
build="$1"; domain="$2"
root="$build/tests/task_space/activation_session"
rm -rf "$root"; mkdir -p "$root"
op="$build/services/task_space/hexa_operator"
out="$root"
. "$(dirname "$0")/operator_session_lib.sh"

start_session() {  # start_session NAME ARGS...: a session in $root/NAME, until it has a pose
  local name="$1"; shift
  launch_session "$name" 'pose estimate available' 60 --trajectory combined --periods 1 --seed 3 \
      --activation operator --hold-timeout 600 --timeout 280 "$@"
}
end_session() {  # shuts the session down and waits for it
  "$op" --domain "$domain" --wait 30 shutdown > "$out/op_shutdown.log" 2>&1 || true
  wait "$session" || true
}
refused() {  # refused NAME WORDS: a start refused (exit 4) with WORDS in the operator's message
  run "$1" 4 start
  check "grep -qF '$2' '$out/op_$1.log'" "the refusal names: $2"
  check "grep -qF 'activation REFUSED' '$out/plant.log'" "the plant logs the refusal"
}

# 1. E-stop open, then activation granted and the trajectory completed.
start_session estop
check "grep -q 'hardware inactive: every valve at its safe value until an operator start or home' '$out/plant.log'" \
      "the plant starts inactive"
run estop_command 0 estop
refused start_estop "e-stop open (the latch is set)"
run reset 0 reset
run start 0 start
check "grep -qF 'activation granted (start): hardware active' '$out/plant.log'" "the activation is granted"
rc=0; wait "$session" || rc=$?
check "[ $rc -eq 0 ]" "the session completes the trajectory after the activation (exit $rc)"
granted=$(grep -oE 'tick [0-9]+: activation granted' "$out/plant.log" | grep -oE '[0-9]+' | head -1)
"$build/services/recorder/hexa_recorder" export "$out/session.mcap" --out-dir "$out/export" \
    --topics hexa_GroundTruth > "$out/export.log" 2>&1 || { echo "FAIL: export"; cat "$out/export.log"; fail=1; }
/usr/bin/python3 - "$out/export/hexa_GroundTruth.csv" "$granted" <<'EOF' || fail=1
import csv, sys
path, granted = sys.argv[1], int(sys.argv[2])
rows = list(csv.DictReader(open(path)))
cols = [c for c in rows[0] if c.startswith("applied_valve_v")]
tick_col = [c for c in rows[0] if c.startswith("header.tick")][0]
assert len(cols) == 6, cols
before = [r for r in rows if int(r[tick_col]) <= granted]
after = [r for r in rows if int(r[tick_col]) > granted + 1]
off_null = [(r[tick_col], c, r[c]) for r in before for c in cols if float(r[c]) != 5.0]
moving = sum(1 for r in after for c in cols if abs(float(r[c]) - 5.0) > 0.05)
vel = [c for c in rows[0] if c.startswith("piston_velocity_m_s")]
first_s = [r for r in after if int(r[tick_col]) <= granted + 1000]
peak = max(abs(float(r[c])) for r in first_s for c in vel)
idle = max(abs(float(r[c])) for r in before for c in vel)
print(f"largest leg speed: {idle * 1e3:.2f} mm/s while inactive, {peak * 1e3:.2f} mm/s in the first "
      f"second after the activation")
print(f"ground truth: {len(before)} ticks up to the activation at tick {granted}, "
      f"{len(off_null)} valve values off null among them; {moving} valve values off null after")
ok = len(before) > 100 and not off_null and moving > 1000
print(("ok: " if ok else "FAIL: ") + "valves at null while inactive, following the commands once active")
sys.exit(0 if ok else 1)
EOF

# 2. Supply pressure low.
start_session supply --plant-fault supply-loss:0:0.0
refused start_supply "supply pressure low"
end_session

# 3. A sensor out of range (a dead cap-pressure sensor reads 0 Pa).
start_session sensor --plant-fault pressure-dead:2:0.0
refused start_sensor "sensor out of range: leg 2 cap_pressure_pa = 0 outside"
end_session

# 4. A leg without a live controller.
start_session nolive --fault 3:crash:0.1
for _ in $(seq 1 300); do grep -q 'leg 3' "$out/plant.log" 2>/dev/null && grep -qiE 'ended|gone|dead' "$out/plant.log" && break; sleep 0.1; done
refused start_nolive "no live controller for leg 3"
end_session

exit $fail
