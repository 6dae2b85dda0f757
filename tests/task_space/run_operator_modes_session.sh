#!/usr/bin/env bash
# ctest driver of task_space.operator_modes_session: a lockstep session over DDS (eight
# processes and the recorder, `hexa_session --wait-for-operator`, own domain) driven with
# hexa_operator as a user runs it: a jog (+x, work frame) let go, a tool-frame jog, a pose goal,
# a goal outside the soft limits (refused, exit 4, the reason), bad arguments (exit 2), then
# shutdown. Checked against the recording's ground truth (pose.csv): the jog moved the platform
# along +x and was at rest within the dead-man time plus the braking time after its last message;
# the goal was reached within the stated tolerance.
# Usage: run_operator_modes_session.sh BUILD_DIR DOMAIN
set -euo pipefail
build="$1"; domain="$2"
out="$build/tests/task_space/operator_modes_session"
rm -rf "$out"; mkdir -p "$out"
op="$build/services/task_space/hexa_operator"
. "$(dirname "$0")/operator_session_lib.sh"

"$build/deploy/hexa_session" --trajectory combined --periods 1 --seed 3 --domain "$domain" \
    --out "$out" --wait-for-operator --timeout 240 > "$out/hexa_session.out" 2>&1 &
session=$!; pids+=("$session")
export HEXA_SESSION_KEY="$out/session.key"

# The supervisor answers once it has a pose estimate: until then a jog is refused (exit 4).
rest=""
for _ in $(seq 1 600); do
  rest=$(grep -oE 'rest pose \([-0-9., ]+\) m, \([-0-9., ]+\) deg' "$out/supervisor.log" 2>/dev/null | head -1) || true
  [ -n "$rest" ] && break
  kill -0 "$session" 2>/dev/null || { echo "FAIL: the session ended before the supervisor ran"; tail -20 "$out/hexa_session.out"; exit 1; }
  sleep 0.1
done
[ -n "$rest" ] || { echo "FAIL: no pose estimate in supervisor.log"; exit 1; }
echo "supervisor: $rest"
read -r rx ry rz < <(echo "$rest" | sed -E 's/rest pose \(([-0-9.]+), ([-0-9.]+), ([-0-9.]+)\).*/\1 \2 \3/')

# Short (wall time; lockstep runs faster than real time here): let go well before the box's
# x = +0.1 m, so that the braking is what is measured.
run jog_x 0 jog --velocity-m-s 0.04,0,0 --duration-s 0.5 --rate-hz 50
check "wait_log 'jog at rest at t' 1" "the jog came to rest (supervisor.log)"
run jog_tool 0 jog --frame tool --velocity-m-s 0,0.03,0 --duration-s 0.5 --rate-hz 50
check "wait_log 'jog at rest at t' 2" "the tool-frame jog came to rest"
add() { awk -v a="$1" -v b="$2" 'BEGIN { printf "%.6f", a + b }'; }
gx=$(add "$rx" 0.02); gy=$(add "$ry" -0.015); gz=$(add "$rz" 0.01)
run goal 0 goal --position-m "$gx,$gy,$gz" --rpy-deg 2,0,3
check "wait_log 'goal motion at rest at t' 1" "the goal was reached (supervisor.log)"
far=$(add "$rx" 0.2)
run goal_outside 4 goal --position-m "$far,$ry,$rz"
check "grep -q 'goal refused: the goal leaves the pose box: x' '$out/op_goal_outside.log'" \
      "the refused goal's reason reaches the operator"
run goal_not_unit 2 goal --position-m "$gx,$gy,$gz" --quaternion 1,0,0,0.1
check "grep -q 'not a unit quaternion' '$out/op_goal_not_unit.log'" "a non-unit quaternion is refused before sending"
run jog_absurd 2 jog --velocity-m-s 5,0,0
sleep 1
# Ends the session (its answer may be lost as the supervisor leaves: exit 0 or 3).
"$op" --domain "$domain" --wait 30 shutdown > "$out/op_shutdown.log" 2>&1 || true
rc=0; wait "$session" || rc=$?
check "[ $rc -eq 0 ]" "hexa_session ends 0 after the shutdown (got $rc)"

grep -E "jog at rest|goal motion at rest|goal started|goal #|refused" "$out/supervisor.log" || true
# Ground truth: pose.csv (time, desired, true, measured); the supervisor's log gives the times.
/usr/bin/python3 - "$out" <<'EOF' || fail=1
import csv, math, re, sys
out = sys.argv[1]
log = open(out + "/supervisor.log").read()
rows = [list(map(float, r)) for r in list(csv.reader(open(out + "/pose.csv")))[1:]]
t = [r[0] for r in rows]
def at(ts, col):  # the row at or after time ts
    for r in rows:
        if r[0] >= ts - 1e-9: return r[col:col + 6]
    return rows[-1][col:col + 6]
DES, TRUE = 1, 7
ok = True
def expect(cond, what):
    global ok
    print(("ok: " if cond else "FAIL: ") + what)
    ok = ok and cond
# Jog +x 0.04 m/s: T_d + v/A + A/J = 0.25 + 0.16 + 0.10 = 0.51 s; travel after the last message
# v T_d + v (v/A + A/J) / 2 = 15.2 mm (docs/operate.md, JogProfileConfig defaults).
m = re.search(r"jog at rest at t = ([0-9.]+) s, ([0-9.]+) s after the last jog message \(t = ([0-9.]+) s\)", log)
rest_t, after_s, last_t = float(m.group(1)), float(m.group(2)), float(m.group(3))
starts = [float(x) for x in re.findall(r"jogging from t = ([0-9.]+) s", log)]
t0 = starts[0]
# The platform 0.3 s after the setpoint came to rest, unless the next jog started before.
t_end = min(rest_t + 0.3, starts[1] - 0.005) if len(starts) > 1 else rest_t + 0.3
p0, p_last, p_rest = at(t0, TRUE), at(last_t, TRUE), at(t_end, TRUE)
d_last, d_rest = at(last_t, DES), at(rest_t, DES)
moved = [p_rest[k] - p0[k] for k in range(3)]
print(f"jog +x: from t = {t0:.3f} s, last message t = {last_t:.3f} s, at rest {after_s:.3f} s later "
      f"(bound 0.510 s + one 5 ms tick); truth at t = {t_end:.3f} s moved ({moved[0]*1e3:.2f}, {moved[1]*1e3:.2f}, "
      f"{moved[2]*1e3:.2f}) mm; after the last message setpoint {1e3*(d_rest[0]-d_last[0]):.2f} mm, "
      f"truth {1e3*(p_rest[0]-p_last[0]):.2f} mm (bound 15.2 mm)")
expect(after_s <= 0.515 + 1e-9, "the jog was at rest within the dead-man time plus braking")
expect(moved[0] > 0.01 and math.hypot(moved[1], moved[2]) < 0.15 * moved[0], "the jog moved the platform along +x")
expect(d_last[0] < 0.1 - 0.0152, "let go before the box limit (what stopped it is the braking)")
expect(d_rest[0] - d_last[0] <= 0.0152 + 1e-6, "setpoint travel after the last message within the braking bound")
expect(p_rest[0] - p_last[0] <= 0.0152 + 0.004, "truth travel after the last message within the bound + 4 mm")
# Goal: the platform's move within 4 mm of the one asked, and at rest on the goal within the
# estimator's static offset from the truth (measured at the goal's start) + 4 mm, 8 mrad.
g = re.search(r"goal #[0-9]+: \(([-0-9.]+), ([-0-9.]+), ([-0-9.]+)\) m, \(([-0-9.]+), ([-0-9.]+), ([-0-9.]+)\) rad", log)
goal = [float(g.group(k)) for k in range(1, 7)]
tg0 = float(re.search(r"goal started at t = ([0-9.]+) s", log).group(1))
tg = float(re.search(r"goal motion at rest at t = ([0-9.]+) s", log).group(1))
true0, des0 = at(tg0, TRUE), at(tg0, DES)
true_g, des_g = at(tg + 0.5, TRUE), at(tg, DES)
offset = math.dist(true0[:3], des0[:3])
asked = [goal[k] - des0[k] for k in range(3)]
moved = [true_g[k] - true0[k] for k in range(3)]
err_move = math.dist(asked, moved)
err_p = math.dist(true_g[:3], goal[:3]); err_r = max(abs(true_g[k] - goal[k]) for k in range(3, 6))
print(f"goal: planned from t = {tg0:.3f} s, at rest t = {tg:.3f} s; setpoint {1e3*math.dist(des_g[:3], goal[:3]):.4f} mm "
      f"from it; platform 0.5 s later {err_p*1e3:.2f} mm, {err_r*1e3:.2f} mrad from it (static offset of "
      f"the estimate from the truth before: {offset*1e3:.2f} mm); move {1e3*math.hypot(*asked):.2f} mm asked, "
      f"{err_move*1e3:.2f} mm off")
expect(math.dist(des_g[:3], goal[:3]) < 1e-4, "the setpoint ended on the goal (to the log's 0.1 mm)")
expect(err_move < 0.004, "the platform's move within 4 mm of the one asked")
expect(err_p < offset + 0.004 and err_r < 0.008, "the platform at rest on the goal within the static offset + 4 mm, 8 mrad")
sys.exit(0 if ok else 1)
EOF
echo "operator_modes_session: $([ $fail -eq 0 ] && echo PASSED || echo FAILED)"
exit $fail
