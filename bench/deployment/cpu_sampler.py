#!/usr/bin/env python3
"""Per-CPU utilisation sampler: /proc/stat per CPU every --interval-ms (default 100).

Writes one CSV row per CPU and interval: the interval's end on the wall clock (CLOCK_REALTIME
ns, the clock of DDS source times and of hexa_multihost_bench's RUN lines), its length, and
the fraction of it each CPU spent in user (incl. nice), system, irq, softirq, steal, iowait
and idle (from the jiffy counters: exact over the interval even when the sampler itself is
woken late). Runs until SIGTERM / SIGINT or --duration-s. Used beside the multi-host benchmark
(bench/deployment/rt_series.sh) and read by bench/deployment/cpu_utilisation.py.
"""
import argparse
import signal
import time

FIELDS = ("user", "nice", "system", "idle", "iowait", "irq", "softirq", "steal")


def read_stat():
    cpus = {}
    with open("/proc/stat") as f:
        for line in f:
            if line.startswith("cpu") and line[3].isdigit():
                parts = line.split()
                cpus[int(parts[0][3:])] = [int(x) for x in parts[1:9]]
    return cpus


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", required=True, help="CSV file to write")
    p.add_argument("--interval-ms", type=float, default=100.0)
    p.add_argument("--duration-s", type=float, default=0.0, help="0: until SIGTERM")
    a = p.parse_args()
    stop = []
    signal.signal(signal.SIGTERM, lambda *_: stop.append(1))
    signal.signal(signal.SIGINT, lambda *_: stop.append(1))
    period = a.interval_ms / 1e3
    end = time.monotonic() + a.duration_s if a.duration_s > 0 else float("inf")
    with open(a.out, "w", buffering=1) as out:
        out.write("t_ns,interval_s,cpu,user,system,irq,softirq,steal,iowait,idle\n")
        prev, prev_t = read_stat(), time.monotonic()
        next_t = prev_t + period
        while not stop and time.monotonic() < end:
            time.sleep(max(0.0, next_t - time.monotonic()))
            # Late (the sampler runs at normal priority beside SCHED_FIFO work): the next
            # interval starts now, never a near-empty one.
            next_t = max(next_t + period, time.monotonic() + period / 2)
            cur, t = read_stat(), time.monotonic()
            wall = time.time_ns()
            for cpu, c in sorted(cur.items()):
                d = [x - y for x, y in zip(c, prev.get(cpu, c))]
                total = sum(d)
                if total <= 0:
                    continue
                v = dict(zip(FIELDS, d))
                out.write("%d,%.4f,%d,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f\n" % (
                    wall, t - prev_t, cpu, (v["user"] + v["nice"]) / total, v["system"] / total,
                    v["irq"] / total, v["softirq"] / total, v["steal"] / total, v["iowait"] / total,
                    v["idle"] / total))
            prev, prev_t = cur, t


if __name__ == "__main__":
    main()
