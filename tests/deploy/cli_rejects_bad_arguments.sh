#!/bin/sh
# Every user-facing CLI rejects a single-dash option, a stray word and a non-finite time with
# exit status 2 and a message naming the argument, before starting anything (no DDS traffic:
# each case fails in argument parsing). Usage: cli_rejects_bad_arguments.sh BUILD_DIR
B="$1"
fail=0
expect() {  # expect "<regex on stderr>" command...
  pattern="$1"; shift
  err=$("$@" 2>&1 >/dev/null); rc=$?
  if [ "$rc" -ne 2 ] || ! printf '%s' "$err" | grep -q -- "$pattern"; then
    echo "FAIL: $* -> exit $rc, stderr: $(printf '%s' "$err" | head -c 300)"
    fail=1
  else
    echo "ok:   $* -> exit 2: $(printf '%s' "$err" | head -n 1 | head -c 160)"
  fi
}
expect "unknown option '-trajectory'.*--trajectory" "$B/deploy/hexa_session" -trajectory x
expect "unexpected argument 'x'" "$B/deploy/hexa_session" x
expect "time_s a finite number" "$B/deploy/hexa_session" --fault 1:crash:inf
expect "time_s a finite number" "$B/deploy/hexa_session" --fault 1:crash:nan
expect "time_s a finite number" "$B/deploy/hexa_session" --fault 1:crash:-1
expect "leg 3 already has a fault (--fault 3:crash:1); one fault per process" "$B/deploy/hexa_session" --fault 3:crash:1 --fault 3:hang:2
expect "the supervisor already has a fault" "$B/deploy/hexa_session" --fault supervisor:crash:1 --fault supervisor:crash:2
expect "bridge-port.*70000" "$B/deploy/hexa_session" --bridge --bridge-port 70000
expect "bridge-port" "$B/deploy/hexa_session" --bridge-port -1
expect "record-keep-files needs --record-split-mb or --record-split-s" "$B/deploy/hexa_session" --record-keep-files 3
expect "hold-timeout" "$B/deploy/hexa_session" --hold-timeout 0
expect "unknown option '-leg'" "$B/services/leg_ctrl/hexa_leg_ctrl" -leg 1
expect "fault-at.*not a finite number" "$B/services/leg_ctrl/hexa_leg_ctrl" --leg 1 --fault crash --fault-at inf
expect "unknown option '-trajectory'" "$B/services/task_space/hexa_task_space" -trajectory x
expect "unexpected argument 'x'" "$B/services/plant_sim/hexa_plant_sim" x
expect "unknown option '-domain'" "$B/services/task_space/hexa_operator" -domain 3 start
expect "unknown option '-trajectory'" "$B/tools/hexa_sim" -trajectory x
expect "unknown option '-o'" "$B/services/recorder/hexa_recorder" recover in.mcap -o out.mcap
expect "unknown option '-out-dir'.*--out-dir" "$B/services/recorder/hexa_recorder" export in.mcap -out-dir d
expect "expects a finite number, got 'inf'" "$B/services/recorder/hexa_recorder" diff a.mcap b.mcap --tolerance-v inf
expect "expects a finite number, got 'nan'" "$B/services/recorder/hexa_recorder" diff a.mcap b.mcap --tolerance-v nan
expect "expects a finite number, got 'inf'" "$B/services/recorder/hexa_recorder" play a.mcap --lockstep --wait-readers-s inf
expect "expects a number or inf, got '-inf'" "$B/services/recorder/hexa_recorder" play a.mcap --deadline-s -inf
exit $fail
