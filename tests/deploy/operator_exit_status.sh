#!/bin/sh
# hexa_operator's exit status says whether the command arrived (docs/exit_codes.md):
#   0  acknowledged by every matched reader;
#   1  the supervisor's command reader (or, with --to any-reader, any reader) did not match
#      within --wait: a recorder alone is not the supervisor (a command written before the
#      supervisor's reader matched would never reach it).
# Exit 3 (sent, but a matched reader never acknowledged it; logged at error level, where it
# used to be an info line with exit 0) is not exercised here: a reader that matches and then
# never acknowledges cannot be made without a race (a reader stopped with SIGSTOP before the
# write is never matched, since discovery needs it too).
# Usage: operator_exit_status.sh BUILD_DIR
B="$1"
if [ -z "$HEXA_OPERATOR_TEST_NETNS" ] && unshare -n true 2>/dev/null; then
  # A private network namespace when we may make one (root): no other test's DDS traffic.
  exec env HEXA_OPERATOR_TEST_NETNS=1 unshare -n sh -c 'ip link set lo up && exec "$0" "$@"' "$0" "$@"
fi
DOMAIN=$((120 + $$ % 20))
DIR=$(mktemp -d)
READER=""
SUPERVISOR=""
cleanup() {
  for p in $READER $SUPERVISOR; do
    kill -CONT "$p" 2>/dev/null
    kill -TERM "$p" 2>/dev/null
    wait "$p" 2>/dev/null
  done
  rm -rf "$DIR"
}
trap cleanup EXIT INT TERM
fail=0
check() {  # check <expected rc> <regex on the log> <label> -- command...
  want="$1"; pattern="$2"; label="$3"; shift 4
  "$@" >"$DIR/op.log" 2>&1; rc=$?
  if [ "$rc" -ne "$want" ] || ! grep -q -- "$pattern" "$DIR/op.log"; then
    echo "FAIL: $label: exit $rc (want $want); log: $(tail -c 400 "$DIR/op.log")"
    fail=1
  else
    echo "ok:   $label: exit $rc: $(grep -- "$pattern" "$DIR/op.log" | head -n 1 | cut -c 1-200)"
  fi
}

check 1 "no supervisor on domain $DOMAIN" "nobody listening" -- \
  "$B/services/task_space/hexa_operator" --domain "$DOMAIN" --wait 0.3 reset

"$B/services/recorder/hexa_recorder" record --output "$DIR/ops.mcap" --domain "$DOMAIN" \
  --topics hexa_OperatorCommand >"$DIR/recorder.log" 2>&1 &
READER=$!
check 1 "no supervisor on domain $DOMAIN within 3 s (1 other reader(s)" "a recorder alone is not the supervisor" -- \
  "$B/services/task_space/hexa_operator" --domain "$DOMAIN" --wait 3 --linger 0.1 reset
check 0 "matched, acknowledged" "a recorder alone, --to any-reader" -- \
  "$B/services/task_space/hexa_operator" --domain "$DOMAIN" --wait 10 --linger 0.1 --to any-reader reset

# A supervisor (lockstep, waiting for its peers: its command reader exists from the start).
"$B/services/task_space/hexa_task_space" --domain "$DOMAIN" >"$DIR/supervisor.log" 2>&1 &
SUPERVISOR=$!
check 0 "(2 reader(s) matched, acknowledged)" "supervisor and recorder running" -- \
  "$B/services/task_space/hexa_operator" --domain "$DOMAIN" --wait 10 --linger 0.1 reset

exit $fail
