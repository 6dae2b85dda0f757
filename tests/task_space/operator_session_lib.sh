# Shared by the ctest drivers of sessions driven with hexa_operator (run_operator_modes_session.sh,
# run_stream_session.sh); sourced after they set `out` (the session's directory), `op`
# (hexa_operator) and `domain`. Processes the driver starts go into `pids` and end with it.
pids=()
cleanup() { for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done; wait 2>/dev/null || true; }
trap cleanup EXIT
fail=0
check() { if eval "$1"; then echo "ok: $2"; else echo "FAIL: $2"; fail=1; fi; }

run() {  # run NAME EXPECTED_EXIT ARGS...: hexa_operator, its exit status checked
  local name="$1" want="$2"; shift 2
  local rc=0
  "$op" --domain "$domain" --wait 30 --answer-wait 30 "$@" > "$out/op_$name.log" 2>&1 || rc=$?
  check "[ $rc -eq $want ]" "hexa_operator $name exits $want (got $rc)"
  if [ "$rc" -ne "$want" ]; then cat "$out/op_$name.log"; fi
}
# launch_session NAME READY WAIT_S ARGS...: hexa_session ARGS in $root/NAME on $domain (its pid
# in $session, $out set, its session key exported) until supervisor.log holds READY; fails
# the test if the session ends first or READY does not come within WAIT_S.
launch_session() {
  out="$root/$1"; local ready="$2" tries=$(( $3 * 10 )); shift 3
  mkdir -p "$out"
  "$build/deploy/hexa_session" --domain "$domain" --out "$out" "$@" > "$out/hexa_session.out" 2>&1 &
  session=$!; pids+=("$session")
  export HEXA_SESSION_KEY="$out/session.key"
  for _ in $(seq 1 "$tries"); do
    grep -q "$ready" "$out/supervisor.log" 2>/dev/null && return 0
    kill -0 "$session" 2>/dev/null || { echo "FAIL: $out: the session ended before '$ready'"; tail -20 "$out/hexa_session.out"; exit 1; }
    sleep 0.1
  done
  echo "FAIL: $out: no '$ready' in supervisor.log"; exit 1
}
wait_log() {  # wait_log PATTERN COUNT: until supervisor.log holds COUNT lines matching PATTERN
  for _ in $(seq 1 600); do
    [ "$(grep -cE "$1" "$out/supervisor.log" || true)" -ge "$2" ] && return 0
    sleep 0.1
  done
  return 1
}
