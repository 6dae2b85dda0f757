#!/usr/bin/env bash
# The end of real-time sessions (docs/measurements/performance.md, "The end of a real-time session"): runs N
# real-time sessions (combined trajectory, 1 period, seeds 1..N) with each build given,
# alternating builds run by run, and prints per session: exit code, the plant's error lines,
# those within the last 60 ticks, and how many legs' writers were alive when the plant stopped.
# hexa_session pins Cyclone to loopback (deploy/cyclonedds-loopback.xml).
#   bench/session/rt_session_end.sh [-n N] BUILD_DIR [BUILD_DIR ...]
# Run as root for SCHED_FIFO (the launcher asks for it), e.g. inside `unshare -n`.
set -uo pipefail
n=6
if [ "${1:-}" = "-n" ]; then n="$2"; shift 2; fi
if [ $# -lt 1 ] || [ "${1:-}" = "--help" ]; then sed -n 2,8p "$0"; exit 2; fi
for b in "$@"; do
  [ -x "$b/deploy/hexa_session" ] || { echo "error: no $b/deploy/hexa_session (build it first)"; exit 2; }
done
out_root=$(mktemp -d /tmp/rt_session_end.XXXXXX)
trap 'rm -rf "$out_root"' EXIT
for i in $(seq 1 "$n"); do
  k=0
  for b in "$@"; do
    k=$((k + 1))
    out="$out_root/build${k}_seed$i"
    "$b/deploy/hexa_session" --mode realtime --trajectory combined --periods 1 --seed "$i" \
        --domain 92 --out "$out" > "$out_root/console" 2>&1
    rc=$?
    errors=$(grep -c "\[plant\] error" "$out/plant.log")
    last=$(grep -oE "stopped at tick [0-9]+" "$out/plant.log" | grep -oE "[0-9]+$")
    near_end=$(grep "\[plant\] error" "$out/plant.log" | grep -oE "tick [0-9]+:" | grep -oE "[0-9]+" |
               awk -v L="${last:-0}" '$1 >= L - 60' | wc -l)
    alive=$(grep -h "stopped at tick" "$out/plant.log" | grep -oE "primary alive" | wc -l)
    echo "build $k ($b) seed $i: exit $rc, plant errors $errors, in the last 60 ticks $near_end," \
         "last tick ${last:-?}, legs' writers alive at the plant's stop $alive of 6"
  done
done
