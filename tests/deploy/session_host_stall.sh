#!/bin/sh
# A supervisor the host does not run (docs/liveliness.md, "When the host stops a process"):
# a real-time session whose supervisor is stopped (SIGSTOP) for 0.3 s mid-trajectory holds on
# the legs' FAULT_SETPOINT_STALE, and the hold line on the console and in report.md says that
# the host stopped the supervisor (the plant's sample reached it about 300 ms old while the
# process used almost no CPU), not only that its setpoints went stale.
# Usage: session_host_stall.sh BUILD_DIR
B="$1"
if [ -z "$HEXA_SESSION_TEST_NETNS" ] && unshare -n true 2>/dev/null; then
  exec env HEXA_SESSION_TEST_NETNS=1 unshare -n sh -c 'ip link set lo up && exec "$0" "$@"' "$0" "$@"
fi
D=$((160 + $$ % 20))
DIR=$(mktemp -d)
SESSION=""
SUP=""
fail=0
cleanup() {
  [ -n "$SUP" ] && kill -CONT "$SUP" 2>/dev/null
  [ -n "$SESSION" ] && kill -TERM "$SESSION" 2>/dev/null && wait "$SESSION" 2>/dev/null
  if [ "$fail" -eq 0 ]; then rm -rf "$DIR"; else echo "outputs kept in $DIR"; fi
}
trap cleanup EXIT
trap 'exit 1' INT TERM
"$B/deploy/hexa_session" --mode realtime --trajectory combined --periods 1 --seed 1 --domain "$D" \
  --out "$DIR/out" --hold-timeout 1 >"$DIR/console.log" 2>&1 &
SESSION=$!
i=0
while [ "$i" -lt 300 ]; do
  SUP=$(grep -o "started supervisor (pid [0-9]*" "$DIR/console.log" 2>/dev/null | grep -o "[0-9]*$")
  [ -n "$SUP" ] && grep -q "trajectory 'combined' accepted" "$DIR/out/supervisor.log" 2>/dev/null && break
  sleep 0.1
  i=$((i + 1))
done
if [ -z "$SUP" ]; then echo "FAIL: the session did not start: $(tail -c 600 "$DIR/console.log")"; fail=1; exit 1; fi
sleep 2
kill -STOP "$SUP"
sleep 0.3
kill -CONT "$SUP"
wait "$SESSION"
rc=$?
SESSION=""
hold=$(grep "session did NOT complete" "$DIR/console.log")
echo "session exit $rc: $hold"
if [ "$rc" -ne 3 ]; then echo "FAIL: exit $rc, want 3 (held)"; fail=1; fi
case "$hold" in
  *"the host stopped the supervisor: the plant's tick "*" reached it "*" ms old, while it ran "*) ;;
  *) echo "FAIL: the console's hold line does not name the host's stall"; fail=1 ;;
esac
if ! grep -q "the host stopped the supervisor" "$DIR/out/report.md"; then
  echo "FAIL: report.md does not name the host's stall"; fail=1
fi
# The age the supervisor measured covers the stop (300 ms, less what the plant's own sample
# age already was).
age=$(echo "$hold" | sed -n "s/.*reached it \([0-9.]*\) ms old.*/\1/p")
if [ -z "$age" ] || awk -v a="$age" 'BEGIN { exit !(a < 250) }'; then
  echo "FAIL: measured age '$age' ms, want >= 250 for a 300 ms stop"; fail=1
fi
[ "$fail" -eq 0 ] && echo "ok: the hold names the host's stall"
exit "$fail"
