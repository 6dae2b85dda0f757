#!/usr/bin/env bash
# The main job on a fresh Debian 12 machine: install, build, run one complete closed-loop
# session (plant, six leg controllers, supervisor, recorder over loopback DDS) with the
# defaults (combined trajectory, BS-SMC, realistic profile, lockstep) and write the report.
# Extra arguments go to hexa_session (see: build/deploy/hexa_session --help).
#
# Quiet: one line per stage; the output of each stage goes to a log file (build: build/build.log,
# session: <out>/run_main.log). On a terminal the session's last log line is shown as a
# progress line. Ends with the output paths and the headline figures. --verbose prints
# everything instead. Expected duration on a 2-core machine: ~1-2 min with a built tree
# (about 20 s of session and 30 s of report and plots), 10-20 min for a first build.
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
build_dir="${HEXA_BUILD_DIR:-$here/build}"
out="$here/out/session-$(date +%Y%m%d-%H%M%S)"
verbose=0
args=()
for a in "$@"; do
  if [ "$a" = "--verbose" ]; then verbose=1; else args+=("$a"); fi
done
export CYCLONEDDS_URI="${CYCLONEDDS_URI:-file://$here/deploy/cyclonedds-loopback.xml}"
if [ "$verbose" = 1 ]; then
  "$here/scripts/install_deps.sh"
  "$here/scripts/build.sh"
  exec "$build_dir/deploy/hexa_session" --out "$out" ${args[@]+"${args[@]}"}
fi

mkdir -p "$build_dir"
stage() {  # stage TEXT LOG COMMAND...: one line; on failure the log's last lines
  local text="$1" log="$2" t0=$SECONDS
  shift 2
  printf 'run_main: %s ... ' "$text"
  if "$@" >"$log" 2>&1; then
    echo "done ($((SECONDS - t0)) s)"
  else
    echo "FAILED after $((SECONDS - t0)) s; the last lines of $log:"
    tail -n 25 "$log"
    exit 1
  fi
}
stage "Debian packages" "$build_dir/install_deps.log" "$here/scripts/install_deps.sh"
stage "build (output in $build_dir/build.log)" "$build_dir/build.log" "$here/scripts/build.sh"

mkdir -p "$out"
log="$out/run_main.log"
echo "run_main: session (output in $log)"
t0=$SECONDS
"$build_dir/deploy/hexa_session" --out "$out" ${args[@]+"${args[@]}"} >"$log" 2>&1 &
pid=$!
trap 'kill -INT $pid 2>/dev/null; wait $pid; exit 130' INT TERM
if [ -t 1 ]; then
  cols=$(tput cols 2>/dev/null || echo 100)
  while kill -0 $pid 2>/dev/null; do
    last="$(grep -v '^\s*$' "$log" 2>/dev/null | tail -n 1 | sed -E 's/^\[[^]]*\] //')"
    printf '\r\033[K  %3d s  %s' $((SECONDS - t0)) "${last:0:$((cols - 10))}"
    sleep 1
  done
  printf '\r\033[K'
fi
rc=0
wait $pid || rc=$?
trap - INT TERM
if [ $rc -ne 0 ]; then
  echo "run_main: session FAILED (exit $rc, docs/faults.md) after $((SECONDS - t0)) s; the last lines of $log:"
  tail -n 15 "$log"
  echo "run_main: outputs in $out"
  exit $rc
fi
echo "run_main: session completed in $((SECONDS - t0)) s"
echo "run_main: outputs in $out"
echo "  report:  $out/report.md (summary: $out/summary.png)"
echo "  record:  $out/session.mcap"
/usr/bin/python3 - "$out/report.json" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
t = r["rmse_vs_ground_truth"]
print("  RMSE vs ground truth: x %.3f y %.3f z %.3f cm, roll %.3f pitch %.3f yaw %.3f deg" % (
    100 * t["x_m"], 100 * t["y_m"], 100 * t["z_m"],
    *(57.29577951308232 * t[a + "_rad"] for a in ("roll", "pitch", "yaw"))))
print("  simulated %.1f s, wall %.1f s, faults: %d, final state %s" % (
    r["sim_time_s"], r["wall_time_s"], len(r["faults"]), r["final_supervisor_state"]))
PY
