#!/usr/bin/env bash
# ctest driver of task_space.session_ends: lockstep sessions over DDS (own domain) that the
# operator ends, and what hexa_session's exit status, its console's last line and report.md say
# (docs/exit_codes.md: only the trajectory's end is completion; a jog, goal, stream or home
# does not end a session):
#   1. --wait-for-operator, shutdown before any start: exit 6, "shut down by the operator
#      before the trajectory started", never "completed: yes".
#   2. --wait-for-operator, home: the session goes on after the home's end; then shutdown:
#      exit 6, "... before the trajectory started (operator motions only: home)".
#   3. the trajectory running, stop then shutdown: exit 6, "stopped by the operator at
#      trajectory time T s" (the stop ended the motion, the shutdown came after it).
#   4. the trajectory running, shutdown: the operator says accepted (exit 0); exit 6, "shut down
#      by the operator at trajectory time T s (SUPERVISOR_...)".
#   5. the trajectory running, the supervisor stopped by SIGTERM (it exits 0): not completed,
#      exit 1, "the supervisor was stopped by signal 15 ..." (was "completed: yes").
# Usage: run_session_ends.sh BUILD_DIR DOMAIN
set -euo pipefail
build="$1"; domain="$2"
root="$build/tests/task_space/session_ends"
rm -rf "$root"; mkdir -p "$root"
op="$build/services/task_space/hexa_operator"
out="$root"
. "$(dirname "$0")/operator_session_lib.sh"

# start_session NAME LOG_LINE ARGS...: a session in $root/NAME, until supervisor.log has LOG_LINE.
start_session() {
  local name="$1" ready="$2"; shift 2
  launch_session "$name" "$ready" 120 --trajectory x --periods 3 --seed 3 --timeout 280 "$@"
}
# shutdown_session [WAIT_S [EXITS]]: hexa_operator shutdown; its answer may be lost as the
# supervisor leaves: exit 0 or 3 (and 1 where the supervisor may be gone already).
shutdown_session() {
  local rc=0 wait_s="${1:-30}" allowed="${2:-0 3}"
  "$op" --domain "$domain" --wait "$wait_s" shutdown > "$out/op_shutdown.log" 2>&1 || rc=$?
  check "echo ' $allowed ' | grep -q ' $rc '" "hexa_operator shutdown exits one of $allowed (got $rc)"
}
# ended NAME REGEX [EXIT]: the session exited EXIT (6) and its console and report.md say REGEX
# (extended; a '.' stands for an apostrophe) as the reason it did not complete.
ended() {
  local rc=0 want="${3:-6}"; wait "$session" || rc=$?
  check "[ $rc -eq $want ]" "$1: hexa_session exits $want (got $rc)"
  check "grep -qE 'session did NOT complete \\(exit $want\\): $2(;|\$)' '$out/hexa_session.out'" \
        "$1: the console: $(grep -E 'session (did NOT complete|completed)' "$out/hexa_session.out" | tail -1 | cut -c 1-200)"
  check "grep -qE '^- completed: NO: $2\$' '$out/report.md'" \
        "$1: report.md: $(grep -E '^- completed' "$out/report.md" 2>/dev/null)"
}

# 1. Shut down before the trajectory started.
start_session before_start 'pose estimate available' --wait-for-operator
shutdown_session
ended before_start "shut down by the operator before the trajectory started"

# 2. A home is not the trajectory: the session goes on after it.
start_session home 'pose estimate available' --wait-for-operator
run home 0 home
check "wait_log 'home motion at rest at t = ' 1" "the home motion ended (supervisor.log)"
sleep 1
check "kill -0 $session 2>/dev/null" "the session goes on after the home's end"
shutdown_session
ended home "shut down by the operator before the trajectory started \\(operator motions only: home\\)"

# 3. Stop, then shutdown: the stop ended the motion. The shutdown comes while the platform
# stops, or after the stop ended the session (then no supervisor is left: exit 1).
start_session stop_shutdown "trajectory 'x' accepted"
run stop_command 0 stop
shutdown_session 5 "0 1 3"
ended stop_shutdown "stopped by the operator at trajectory time [0-9.]+ s( \\(then shut down\\))? before the trajectory.s end"

# 4. Shutdown during the motion: the supervisor answers and stops within the same tick; the
# operator reports it accepted (its answer, or the supervisor's STOPPING status when a reader
# keeps only the newest status).
start_session shutdown "trajectory 'x' accepted"
run shutdown 0 shutdown
check "grep -q 'sent shutdown to domain $domain: the supervisor \\(command #[0-9]* shutdown: accepted\\|is stopping\\)' '$out/op_shutdown.log'" \
      "hexa_operator says the shutdown was accepted"
ended shutdown "shut down by the operator at trajectory time [0-9.]+ s \\(SUPERVISOR_[A-Z]+\\) before the trajectory.s end"

# 5. The supervisor stopped by a signal: it exits 0, but the trajectory did not finish.
start_session sigterm "trajectory 'x' accepted"
supervisor=$(pgrep -f -- "--end-report $out/end.txt" | head -1) || true
check "[ -n '$supervisor' ]" "the supervisor's pid ($supervisor)"
[ -n "$supervisor" ] && kill -TERM "$supervisor"
ended sigterm "the supervisor was stopped by signal 15 \\(Terminated\\) before the trajectory.s end" 1

echo "session_ends: $([ $fail -eq 0 ] && echo PASSED || echo FAILED)"
exit $fail
