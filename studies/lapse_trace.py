#!/usr/bin/python3
"""Kernel trace of real-time sessions, kept for the runs whose plant reports a fault.

Runs beside rt_series.sh or hexa_session (as root, in the real-time window). It sets up
ftrace (tracefs at /sys/kernel/debug/tracing; trace clock mono; one ring buffer per CPU,
overwriting) with the scheduler, softirq, hard-irq, network-receive and page-fault events,
then watches for plant logs (GLOB). Each new plant log clears the buffer and starts the trace;
the first "liveliness lost" / "valve command stale" line of that log writes a marker (the
wall and monotonic time it saw the line), stops the trace and saves it with the thread list
(`ps -eLo`) as OUT/trace-<n>.txt and OUT/threads-<n>.txt. A run that ends without a fault
("stopped at tick") is not kept unless --keep-clean.

  lapse_trace.py --out DIR [--glob '/tmp/hx15b-*/run/hexa-plant.log'] [--buffer-kb 65536]
Stop it with SIGTERM/SIGINT (it turns tracing off and restores the event set).
"""
import argparse
import glob
import os
import signal
import subprocess
import sys
import time

T = "/sys/kernel/debug/tracing"
EVENTS = [
    "sched/sched_switch", "sched/sched_wakeup", "sched/sched_waking", "sched/sched_wakeup_new",
    "sched/sched_migrate_task",
    "irq/softirq_raise", "irq/softirq_entry", "irq/softirq_exit",
    "irq/irq_handler_entry", "irq/irq_handler_exit",
    "net/netif_rx", "net/netif_receive_skb", "net/net_dev_xmit", "napi/napi_poll",
    "exceptions/page_fault_user", "exceptions/page_fault_kernel",
]
FAULT_WORDS = ("liveliness lost", "valve command stale")


def put(name, value):
    with open(os.path.join(T, name), "w") as f:
        f.write(value)


def setup(buffer_kb):
    put("tracing_on", "0")
    put("current_tracer", "nop")
    put("set_event", "")
    put("trace_clock", "mono")
    put("buffer_size_kb", str(buffer_kb))
    put("options/record-tgid", "1")
    put("options/overwrite", "1")
    for e in EVENTS:
        if os.path.exists(os.path.join(T, "events", e, "enable")):
            put(os.path.join("events", e, "enable"), "1")
        else:
            print(f"lapse_trace: no event {e}", file=sys.stderr)
    put("trace", "")


def teardown():
    put("tracing_on", "0")
    put("set_event", "")
    put("trace", "")
    put("buffer_size_kb", "1408")


def marker(text):
    with open(os.path.join(T, "trace_marker"), "w") as f:
        f.write(text)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", required=True)
    ap.add_argument("--glob", default="/tmp/hx15b-*/run/hexa-plant.log")
    ap.add_argument("--buffer-kb", type=int, default=65536)
    ap.add_argument("--keep-clean", action="store_true")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    started = time.time()
    setup(a.buffer_kb)
    stop = []
    signal.signal(signal.SIGTERM, lambda *_: stop.append(1))
    signal.signal(signal.SIGINT, lambda *_: stop.append(1))
    seen = set()
    current = None  # (path, offset, done)
    n = 0
    log = open(os.path.join(a.out, "lapse_trace.log"), "a")
    try:
        while not stop:
            for p in glob.glob(a.glob):
                if p in seen:
                    continue
                try:
                    if os.path.getmtime(p) < started:
                        seen.add(p)
                        continue
                except OSError:
                    continue
                seen.add(p)
                put("tracing_on", "0")
                put("trace", "")
                put("tracing_on", "1")
                marker(f"LAPSE_TRACE start {p} wall {time.time():.6f} mono {time.monotonic():.6f}")
                current = [p, 0, False]
                print(f"{time.strftime('%H:%M:%S')} tracing {p}", file=log, flush=True)
            if current and not current[2]:
                try:
                    with open(current[0]) as f:
                        f.seek(current[1])
                        chunk = f.read()
                except OSError:
                    chunk = ""
                # Only whole lines.
                cut = chunk.rfind("\n") + 1
                current[1] += len(chunk[:cut].encode())
                lines = chunk[:cut].splitlines()
                fault = next((l for l in lines if any(w in l for w in FAULT_WORDS)), None)
                clean_end = any("stopped at tick" in l for l in lines)
                if fault or clean_end:
                    wall, mono = time.time(), time.monotonic()
                    marker(f"LAPSE_TRACE {'fault' if fault else 'end'} wall {wall:.6f} mono {mono:.6f}: {fault or 'clean'}")
                    put("tracing_on", "0")
                    current[2] = True
                    if fault or a.keep_clean:
                        n += 1
                        kind = "trace" if fault else "clean"
                        with open(os.path.join(a.out, f"threads-{n}.txt"), "w") as f:
                            f.write(f"# {current[0]}\n")
                            subprocess.run(["ps", "-eLo", "pid,tid,cls,rtprio,ni,psr,comm,args"],
                                           stdout=f, check=False)
                        with open(os.path.join(a.out, f"{kind}-{n}.txt"), "w") as f:
                            f.write(f"# {current[0]}\n")
                            subprocess.run(["nice", "-n", "19", "cat", os.path.join(T, "trace")],
                                           stdout=f, check=False)
                        print(f"{time.strftime('%H:%M:%S')} saved {kind}-{n} ({fault or 'clean'})",
                              file=log, flush=True)
            time.sleep(0.02)
    finally:
        teardown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
