#!/bin/sh
# One real-time series of the multi-host benchmark with its witnesses (docs/measurements/deployment.md): hexa_cpu_stall_probe (SCHED_FIFO 99 per CPU, stalls > 2 ms) and the per-CPU
# utilisation sampler (/proc/stat every 100 ms) run beside
# `hexa_multihost_bench ARGS...`; then cpu_utilisation.py lays both beside each run.
#   bench/deployment/rt_series.sh OUT_DIR BUILD_DIR [hexa_multihost_bench arguments...]
# Needs root (namespaces, nftables, SCHED_FIFO). Writes OUT_DIR/bench.txt, cpu.csv,
# cpu_stall_probe.json, utilisation.txt, ps.txt (the busiest processes every 5 s), and with
# --capture-drops dropped.txt (bench/deployment/dropped_datagrams.py per lossy run).
set -u
out=$1; build=$(cd "$2" && pwd) || exit 2; shift 2  # absolute: the bench links its binaries
src=$(cd "$(dirname "$0")/../.." && pwd)
mkdir -p "$out"
"$build/bench/faults/hexa_cpu_stall_probe" --out "$out/cpu_stall_probe.json" --threshold-us 2000 \
  >"$out/probe.log" 2>&1 &
probe=$!
/usr/bin/python3 "$src/bench/deployment/cpu_sampler.py" --out "$out/cpu.csv" --interval-ms 100 &
sampler=$!
# What else ran: the busiest processes every 5 s (the load average counts frozen jobs too).
( while :; do date -u +%T; ps -eo pid,ni,stat,pcpu,etimes,comm --sort=-pcpu | head -12; sleep 5; done ) \
  >"$out/ps.txt" 2>&1 &
ps_loop=$!
sleep 0.5
echo "window $(date -u +%H:%M:%S) $*" >"$out/bench.txt"
"$build/bench/deployment/hexa_multihost_bench" --build "$build" "$@" >>"$out/bench.txt" 2>"$out/bench.err"
rc=$?
echo "end $(date -u +%H:%M:%S) exit $rc" >>"$out/bench.txt"
kill -TERM "$probe" "$sampler" "$ps_loop"
wait "$probe" "$sampler" "$ps_loop"
/usr/bin/python3 "$src/bench/deployment/cpu_utilisation.py" --bench "$out/bench.txt" \
  --samples "$out/cpu.csv" --probe "$out/cpu_stall_probe.json" >"$out/utilisation.txt" 2>&1
# With --capture-drops: each lossy run's dropped datagrams attributed to writers, beside the
# recorder's missing samples (OUT/dropped.txt).
for logs in $(sed -n 's/^RUN .*"logs": "\([^"]*\)".*/\1/p' "$out/bench.txt"); do
  [ -f "$logs/dropped.pcap" ] || continue
  { echo "== $logs"; grep -h '^RUN ' "$out/bench.txt" | grep -F "\"$logs\""
    /usr/bin/python3 "$src/bench/deployment/dropped_datagrams.py" --pcap "$logs/dropped.pcap" \
      --recorder-log "$logs/run/hexa-recorder.log"; } >>"$out/dropped.txt" 2>&1
done
exit $rc
