#!/bin/sh
# What hexa_session tells its user (docs/faults.md, "Telling the user what happened"):
#   1. a held platform: the console names the fault and its cause in one line; the session
#      waits for the operator (--hold-timeout); hexa_operator's exit status says refused (4)
#      or accepted (0); a reset resumes the trajectory, which then completes (exit 0). The
#      recording is split every 2 s, keeping 2 files.
#   2. no reset: the session ends held after --hold-timeout (exit 3), the console and
#      report.md say why.
#   3. `hexa_operator stop` during the motion: exit 6 and report.md "completed: NO: stopped by
#      the operator", never "completed: yes"; a reset outside HOLD is refused (exit 4).
#   (`shutdown` during the motion and before the trajectory started: task_space.session_ends.)
#   4. the console's pipe closed at once: the session runs to its end (was killed by SIGPIPE,
#      exit 141, silently).
#   5. two --fault options for two legs: both injected.
#   6. a recorder stopped for 3 s in real time: the trajectory completes, but the recording
#      lost samples: exit 7 and report.md "completed: NO" (was exit 0, "completed: yes").
#      On a machine too loaded for real time the session may hold first: then part 6 says so
#      and checks only that it did not exit 0.
# The fault of 1 and 2 is a FaultEvent from a node outside the loop (fault_event_writer):
# unlike the injected controller faults, its cause goes away, so that a reset can resume.
# Usage: session_operator.sh BUILD_DIR FAULT_EVENT_WRITER
B="$1"
FW="$2"
if [ -z "$HEXA_SESSION_TEST_NETNS" ] && unshare -n true 2>/dev/null; then
  exec env HEXA_SESSION_TEST_NETNS=1 unshare -n sh -c 'ip link set lo up && exec "$0" "$@"' "$0" "$@"
fi
D=$((140 + $$ % 20))
DIR=$(mktemp -d)
SESSION=""
cleanup() {
  [ -n "$SESSION" ] && kill -TERM "$SESSION" 2>/dev/null && wait "$SESSION" 2>/dev/null
  if [ "$fail" -eq 0 ]; then rm -rf "$DIR"; else echo "outputs kept in $DIR"; fi
}
fail=0
trap cleanup EXIT
trap 'exit 1' INT TERM
ok() { echo "ok:   $*"; }
bad() { echo "FAIL: $*"; fail=1; }
# wait_for FILE REGEX SECONDS: true once FILE has a line matching REGEX.
wait_for() {
  i=0
  while [ "$i" -lt $(($3 * 10)) ]; do
    grep -q -- "$2" "$1" 2>/dev/null && return 0
    sleep 0.1
    i=$((i + 1))
  done
  return 1
}
# operator WANT_RC PATTERN COMMAND: hexa_operator's exit status and its message; KEY is the
# session key of the session it commands (hexa_session writes OUT/session.key).
operator() {
  want="$1"; pattern="$2"; shift 2
  "$B/services/task_space/hexa_operator" --domain "$D" --session-key "$KEY" --linger 0.1 "$@" \
    >"$DIR/op.log" 2>&1
  rc=$?
  if [ "$rc" -eq "$want" ] && grep -q -- "$pattern" "$DIR/op.log"; then
    ok "hexa_operator $*: exit $rc: $(grep -- "$pattern" "$DIR/op.log" | head -n 1 | cut -c 1-220)"
  else
    bad "hexa_operator $*: exit $rc (want $want, '$pattern'): $(tail -c 600 "$DIR/op.log")"
  fi
}
session_rc() { wait "$SESSION"; rc=$?; SESSION=""; }

# ---- 1. held, refused, reset, resumed, completed; recording parts.
"$B/deploy/hexa_session" --trajectory x --periods 1 --domain "$D" --out "$DIR/held" \
  --hold-timeout 600 --timeout 500 --record-split-s 2 --record-keep-files 2 >"$DIR/held.console" 2>&1 &
SESSION=$!
wait_for "$DIR/held/supervisor.log" "trajectory 'x' accepted" 180 || bad "1: the trajectory never started"
"$FW" "$D" external_monitor "an external monitor reports an overload" >"$DIR/fw.log" 2>&1 ||
  bad "1: fault_event_writer: $(cat "$DIR/fw.log")"
if wait_for "$DIR/held.console" "platform HOLD: held at t = [0-9.]* s: FAULT_HOST_OVERLOAD, reported by external_monitor: an external monitor reports an overload; waiting up to 600 s" 60; then
  ok "1: console: $(grep "platform HOLD" "$DIR/held.console" | cut -c 1-260)"
else
  bad "1: no console line naming the fault and its cause: $(tail -5 "$DIR/held.console")"
fi
sleep 3
if kill -0 "$SESSION" 2>/dev/null; then ok "1: the session waits in HOLD"; else bad "1: the session ended in HOLD without waiting for the operator"; fi
KEY="$DIR/held/session.key"
operator 4 "refused: the platform is held (SUPERVISOR_HOLD): only reset leaves HOLD" start
operator 0 "reset: accepted" reset
session_rc
if [ "$rc" -eq 0 ] && grep -q "the operator's reset left HOLD" "$DIR/held.console"; then
  ok "1: reset resumed the trajectory, session completed (exit 0)"
else
  bad "1: after the reset: exit $rc: $(tail -5 "$DIR/held.console")"
fi
grep -q "the trajectory starts again from the held pose" "$DIR/held/supervisor.log" ||
  bad "1: the supervisor did not restart the trajectory after the reset"
parts=$(ls "$DIR/held" | grep -c '^session-[0-9]*\.mcap$')
if [ "$parts" -eq 1 ] && [ -f "$DIR/held/session.mcap" ] && [ ! -f "$DIR/held/session-0001.mcap" ]; then
  ok "1: recording split, 2 files kept: $(ls "$DIR/held" | grep '^session.*mcap$' | tr '\n' ' ')"
else
  bad "1: recording files: $(ls "$DIR/held" | grep mcap | tr '\n' ' ') (want session.mcap and one part, part 1 deleted)"
fi
for f in "$DIR"/held/session-*.mcap; do
  "$B/services/recorder/hexa_recorder" info "$f" >"$DIR/info.txt" 2>&1 && grep -q "complete" "$DIR/info.txt" ||
    bad "1: part $f does not read: $(head -c 300 "$DIR/info.txt")"
done

# ---- 2. no reset: ends held after --hold-timeout.
"$B/deploy/hexa_session" --trajectory x --periods 1 --domain "$D" --out "$DIR/timeout" \
  --hold-timeout 2 --timeout 300 >"$DIR/timeout.console" 2>&1 &
SESSION=$!
wait_for "$DIR/timeout/supervisor.log" "trajectory 'x' accepted" 180 || bad "2: the trajectory never started"
"$FW" "$D" external_monitor "an external monitor reports an overload" >"$DIR/fw.log" 2>&1
session_rc
if [ "$rc" -eq 3 ] && grep -q "session did NOT complete (exit 3): held after a fault, no operator reset within --hold-timeout 2 s: held at t = .*FAULT_HOST_OVERLOAD, reported by external_monitor" "$DIR/timeout.console"; then
  ok "2: $(grep "session did NOT complete" "$DIR/timeout.console" | cut -c 1-260)"
else
  bad "2: exit $rc: $(tail -3 "$DIR/timeout.console")"
fi
grep -q "^- completed: NO: held after a fault" "$DIR/timeout/report.md" ||
  bad "2: report.md: $(grep completed "$DIR/timeout/report.md")"
grep -q "external_monitor: leg 0 tick [0-9]* FAULT_HOST_OVERLOAD" "$DIR/timeout/report.md" ||
  bad "2: report.md does not list the fault"

# ---- 3. stop during the motion.
"$B/deploy/hexa_session" --trajectory x --periods 3 --domain "$D" --out "$DIR/stop" \
  --timeout 300 >"$DIR/stop.console" 2>&1 &
SESSION=$!
wait_for "$DIR/stop/supervisor.log" "trajectory 'x' accepted" 180 || bad "3: the trajectory never started"
KEY="$DIR/stop/session.key"
operator 4 "refused: reset only leaves HOLD (state SUPERVISOR_" reset
operator 0 "stop: accepted" stop
session_rc
if [ "$rc" -eq 6 ] && grep -q "session did NOT complete (exit 6): stopped by the operator" "$DIR/stop.console"; then
  ok "3: stop: exit 6: $(grep "session did NOT complete" "$DIR/stop.console" | cut -c 1-200)"
else
  bad "3: stop: exit $rc: $(tail -3 "$DIR/stop.console")"
fi
if grep -q "^- completed: NO: stopped by the operator" "$DIR/stop/report.md" && ! grep -q "^- completed: yes" "$DIR/stop/report.md"; then
  ok "3: report.md: $(grep '^- completed' "$DIR/stop/report.md")"
else
  bad "3: report.md: $(grep completed "$DIR/stop/report.md")"
fi

# ---- 4. the console's pipe closed at once.
( "$B/deploy/hexa_session" --trajectory x --periods 1 --no-recorder --domain "$D" --out "$DIR/pipe" \
    --timeout 300 2>&1; echo $? >"$DIR/pipe.rc" ) | true
rc=$(cat "$DIR/pipe.rc")
# The launcher ran to its end and said how the session ended (completed, or, on a loaded
# machine, held: either way not killed half-way by its console).
if [ "$rc" -ne 141 ] && grep -q "session completed\|session did NOT complete" "$DIR/pipe/session.log"; then
  ok "4: console pipe closed: the launcher ran to its end, exit $rc: $(grep "session completed\|session did NOT complete" "$DIR/pipe/session.log" | cut -c 1-160)"
else
  bad "4: console pipe closed: exit $rc (141 = killed by SIGPIPE): $(tail -2 "$DIR/pipe/session.log")"
fi

# ---- 5. two faults, two legs.
"$B/deploy/hexa_session" --trajectory x --periods 1 --no-recorder --domain "$D" --out "$DIR/two" \
  --fault 2:hang:900 --fault 5:silence:900 --timeout 2 >"$DIR/two.console" 2>&1
if grep -q "fault injection: leg 2 primary controller, 'hang' at t = 900 s" "$DIR/two/session.log" &&
   grep -q "fault injection: leg 5 primary controller, 'silence' at t = 900 s" "$DIR/two/session.log"; then
  ok "5: both faults injected"
else
  bad "5: $(grep "fault injection" "$DIR/two/session.log")"
fi
# ---- 6. the recorder stopped for 3 s in real time.
"$B/deploy/hexa_session" --mode realtime --trajectory x --periods 1 --domain "$D" --out "$DIR/lost" \
  --timeout 300 >"$DIR/lost.console" 2>&1 &
SESSION=$!
wait_for "$DIR/lost/supervisor.log" "trajectory 'x' accepted" 180 || bad "6: the trajectory never started"
sleep 1
REC=$(pgrep -f "hexa_recorder record --output $DIR/lost/session.mcap")
kill -STOP $REC; sleep 3; kill -CONT $REC
session_rc
if grep -q "trajectory finished" "$DIR/lost/supervisor.log"; then
  if [ "$rc" -eq 7 ] && grep -q "^- completed: NO: the trajectory ran to its end, but the recording lost [0-9]* of" "$DIR/lost/report.md"; then
    ok "6: exit 7: $(grep '^- completed' "$DIR/lost/report.md")"
  else
    bad "6: exit $rc: $(grep '^- completed' "$DIR/lost/report.md")"
  fi
elif [ "$rc" -ne 0 ]; then
  echo "note: 6: the real-time session did not finish its trajectory on this machine (exit $rc): only checked that it did not exit 0"
else
  bad "6: exit 0 without finishing the trajectory"
fi
exit $fail
