#!/usr/bin/env bash
# ctest driver of task_space.operator_modes_session: a lockstep session over DDS (eight
# processes and the recorder, `hexa_session --wait-for-operator`, own domain) driven with
# hexa_operator as a user runs it: a jog (+x, work frame) let go, a tool-frame jog, a pose goal,
# a goal outside the soft limits (refused, exit 4, the reason), bad arguments (exit 2), a pivot
# and tool frame (`frames`: absurd ones exit 2, one past the supervisor's bound exit 4), then
# shutdown (exit 6: the trajectory never started, console and report.md say so). Checked
# against the recording's ground truth (pose.csv): the jog moved the platform
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
# The pivot and user frames: absent or absurd (2 m) are usage errors, past the supervisor's bound
# (0.5 m) refused with it (exit 4), a pivot 0.2 m above the platform and a tool frame taken.
run frames_no_pivot 2 frames
check "grep -q 'frames needs --pivot-m' '$out/op_frames_no_pivot.log'" "frames without --pivot-m is a usage error"
run frames_absurd 2 frames --pivot-m 10,0,0
check "grep -q 'pivot_m (10, 0, 0) is 10 m from the platform origin: absurd (limit 2 m)' '$out/op_frames_absurd.log'" \
      "a pivot 10 m away is refused before sending, naming the field, value and limit"
run frames_far 4 frames --pivot-m 0,0,0.8
check "grep -q 'pivot point (from the platform origin) is too far away (value 0.8 m, limit <= 0.5 m)' '$out/op_frames_far.log'" \
      "a pivot 0.8 m away is refused by the supervisor, its bound reaching the operator"
run frames 0 frames --pivot-m 0,0.05,0.2 --tool-position-m 0,0,0.1 --tool-rpy-deg 0,0,90
check "grep -q 'frames set at t = [0-9.]* s: pivot (0.0000, 0.0500, 0.2000) m in the platform frame; tool (0.0000, 0.0000, 0.1000) m, (0.00, 0.00, 90.00) deg' '$out/supervisor.log'" \
      "the supervisor took the pivot and the tool frame (supervisor.log)"
sleep 1
# Ends the session (its answer may be lost as the supervisor leaves: exit 0 or 3).
"$op" --domain "$domain" --wait 30 shutdown > "$out/op_shutdown.log" 2>&1 || true
rc=0; wait "$session" || rc=$?
# Jogs and goals are not the session's trajectory: the shutdown ends it before the trajectory
# started (exit 6, docs/exit_codes.md), and the console and report.md say so.
check "[ $rc -eq 6 ]" "hexa_session ends 6 after the shutdown, the trajectory never started (got $rc)"
check "grep -q 'session did NOT complete (exit 6): shut down by the operator before the trajectory started (operator motions only: jog / goal)' '$out/hexa_session.out'" \
      "the console says the operator shut the session down before the trajectory, after a jog and a goal"
check "grep -q '^- completed: NO: shut down by the operator before the trajectory started' '$out/report.md'" \
      "report.md says the session did not complete"

grep -E "jog at rest|goal motion at rest|goal started|goal #|refused" "$out/supervisor.log" || true
# Ground truth: pose.csv (time, desired, true, measured); the supervisor's log gives the times.
/usr/bin/python3 "$(dirname "$0")/../support/operator_truth.py" "$out" 0.04 || fail=1
echo "operator_modes_session: $([ $fail -eq 0 ] && echo PASSED || echo FAILED)"
exit $fail
