#!/usr/bin/env python3
"""Per-CPU utilisation and CPU stalls of each multi-host benchmark run.

Reads the benchmark's output (its `RUN {...}` lines: wall-clock READY, end and first fault of
each run), the per-CPU samples of bench/deployment/cpu_sampler.py and, if given, the JSON of
hexa_cpu_stall_probe, and prints per run and per CPU the mean share of user, system, softirq,
steal and idle time:
  - over the loop (the plant's READY to the end of the run, minus the last second), and
  - over the --window-s (default 2) before the first fault, for a run that had one;
plus the CPU stalls (wake-ups of the SCHED_FIFO 99 probe later than its threshold) in the run
and the largest one in the window before the first fault. A CPU with idle time left before
the fault was not over capacity then. Used by bench/deployment/rt_series.sh.
"""
import argparse
import csv
import json
import sys


def load_runs(path):
    runs = []
    with open(path) as f:
        for line in f:
            if line.startswith("RUN {"):
                runs.append(json.loads(line[4:]))
    return runs


def load_samples(path):
    rows = []
    with open(path) as f:
        for r in csv.DictReader(f):
            rows.append({k: (int(v) if k in ("t_ns", "cpu") else float(v)) for k, v in r.items()})
    return rows


def mean_shares(samples, t0, t1):
    """{cpu: {field: share}} over samples whose interval ends in (t0, t1], time-weighted."""
    acc = {}
    for s in samples:
        if t0 < s["t_ns"] <= t1:
            a = acc.setdefault(s["cpu"], {"w": 0.0})
            w = s["interval_s"]
            a["w"] += w
            for k in ("user", "system", "irq", "softirq", "steal", "iowait", "idle"):
                a[k] = a.get(k, 0.0) + w * s[k]
    out = {}
    for cpu, a in acc.items():
        if a["w"] > 0:
            out[cpu] = {k: v / a["w"] for k, v in a.items() if k != "w"}
            out[cpu]["seconds"] = a["w"]
    return out


def min_idle(samples, t0, t1):
    """{cpu: lowest idle share of one sample interval} in (t0, t1]."""
    out = {}
    for s in samples:
        if t0 < s["t_ns"] <= t1:
            out[s["cpu"]] = min(out.get(s["cpu"], 1.0), s["idle"])
    return out


def fmt_shares(shares):
    return "; ".join("cpu%d idle %2.0f%% user %2.0f%% sys %2.0f%% softirq %2.0f%% steal %2.0f%% (%.1f s)" % (
        cpu, 100 * v["idle"], 100 * v["user"], 100 * (v["system"] + v["irq"]), 100 * v["softirq"],
        100 * v["steal"], v["seconds"]) for cpu, v in sorted(shares.items())) or "no samples"


def stalls_in(probe, t0, t1):
    ev = [e for e in (probe or {}).get("events", [])
          if e["due_realtime_ns"] + e["late_us"] * 1000 >= t0 and e["due_realtime_ns"] <= t1]
    return ev


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--bench", required=True, help="hexa_multihost_bench output")
    p.add_argument("--samples", required=True, help="cpu_sampler.py CSV")
    p.add_argument("--probe", help="hexa_cpu_stall_probe JSON")
    p.add_argument("--window-s", type=float, default=2.0)
    a = p.parse_args()
    runs = load_runs(a.bench)
    samples = load_samples(a.samples)
    probe = None
    if a.probe:
        try:
            with open(a.probe) as f:
                probe = json.load(f)
        except (OSError, ValueError) as e:
            print("probe: %s" % e, file=sys.stderr)
    w = int(a.window_s * 1e9)
    for r in runs:
        if r["ready_ns"] <= 0:
            print("%s: never READY" % r["scenario"])
            continue
        loop_end = r["end_ns"] - 1000000000
        if r["first_fault_ns"] > 0:
            loop_end = min(loop_end, r["first_fault_ns"])
        print("%s: %s%s" % (r["scenario"], "completed" if r["completed"] else "NOT completed",
                            "; first fault %.2f s after READY: %s" % ((r["first_fault_ns"] - r["ready_ns"]) / 1e9,
                                                                       r["first_fault"])
                            if r["first_fault_ns"] > 0 else ""))
        print("  loop (READY to %s): %s" % ("the first fault" if r["first_fault_ns"] > 0 else "the end - 1 s",
                                           fmt_shares(mean_shares(samples, r["ready_ns"], loop_end))))
        if r["first_fault_ns"] > 0:
            t = r["first_fault_ns"]
            # The interval that ends just after the fault still covers it: include it.
            print("  %.1f s before the first fault: %s" % (a.window_s, fmt_shares(mean_shares(samples, t - w, t + 100000000))))
            mi = min_idle(samples, t - w, t + 100000000)
            print("  lowest idle of one 100 ms sample in that window: %s" %
                  ", ".join("cpu%d %.0f%%" % (c, 100 * v) for c, v in sorted(mi.items())))
        if probe is not None:
            ev = stalls_in(probe, r["ready_ns"], r["end_ns"])
            worst = {}
            for e in ev:
                worst[e["cpu"]] = max(worst.get(e["cpu"], 0), e["late_us"])
            print("  CPU stalls (> %d us) in the run: %d%s" % (probe.get("threshold_us", 0), len(ev),
                  " (largest: %s)" % ", ".join("cpu%d %.1f ms" % (c, v / 1e3) for c, v in sorted(worst.items()))
                  if ev else ""))
            if r["first_fault_ns"] > 0:
                before = stalls_in(probe, r["first_fault_ns"] - w, r["first_fault_ns"])
                big = max(before, key=lambda e: e["late_us"], default=None)
                print("  stall in the %.1f s before the first fault: %s" % (
                    a.window_s, "none" if big is None else "cpu%d %.1f ms (steal %d jiffies), %.0f ms before" % (
                        big["cpu"], big["late_us"] / 1e3, big["steal_jiffies"],
                        (r["first_fault_ns"] - big["due_realtime_ns"]) / 1e6)))


if __name__ == "__main__":
    main()
