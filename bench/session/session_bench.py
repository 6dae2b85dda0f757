#!/usr/bin/python3
"""Session benchmark: the whole system (nine processes + recorder over loopback DDS) on the
combined trajectory, N runs each in lockstep and in real time, side by side in one
invocation. Reports medians over the runs of: simulated seconds per wall second (lockstep
speed), control round-trip latency (sensor sample written -> valve command written, same leg
and tick) median / p99 / max, deadline misses per topic, and the real-time / lockstep RMSE
ratio per axis.

Usage: /usr/bin/python3 bench/session/session_bench.py [--build build] [--runs 3] [--periods 2]
"""
import argparse
import json
import os
import statistics
import subprocess
import sys

AXES = ["x", "y", "z", "roll", "pitch", "yaw"]


def session(build, out, mode, periods, seed, domain):
    cmd = [os.path.join(build, "deploy", "hexa_session"), "--trajectory", "combined",
           "--periods", str(periods), "--mode", mode, "--seed", str(seed), "--out", out,
           "--domain", str(domain), "--timeout", "600"]
    rc = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL).returncode
    path = os.path.join(out, "report.json")
    rep = json.load(open(path)) if os.path.exists(path) else None
    return rc, rep


def main():
    here = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default=os.path.join(here, "build"))
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--periods", type=int, default=2)
    ap.add_argument("--out", default=os.path.join(here, "out", "bench"))
    a = ap.parse_args()
    domain = 200 + os.getpid() % 30
    results = {"lockstep": [], "realtime": []}
    for k in range(a.runs):
        for mode in ["lockstep", "realtime"]:
            rc, rep = session(a.build, os.path.join(a.out, f"{mode}-{k}"), mode, a.periods, 1, domain)
            sys.stderr.write(f"{mode} run {k}: exit {rc}\n")
            if rep is not None and rc == 0:
                results[mode].append(rep)
    print(f"whole-system session benchmark: combined trajectory, {a.periods} periods, seed 1, "
          f"{a.runs} runs per mode (completed: lockstep {len(results['lockstep'])}, "
          f"real time {len(results['realtime'])})")
    for mode, reps in results.items():
        if not reps:
            print(f"{mode}: no completed run")
            continue
        speed = statistics.median(r["sim_time_s"] / r["wall_time_s"] for r in reps)
        lat = {k: statistics.median(r["control_round_trip_latency_s"][k] for r in reps) * 1e6
               for k in ["median", "p99", "max"]}
        print(f"{mode:9s}: sim s / wall s {speed:.2f} (median); round trip median {lat['median']:.0f} us, "
              f"p99 {lat['p99']:.0f} us, max {lat['max']:.0f} us (medians over runs)")
        topics = sorted({t for r in reps for t in r["deadline_misses"]})
        for t in topics:
            m = statistics.median(r["deadline_misses"].get(t, 0) for r in reps)
            print(f"           deadline misses {t}: {m:.0f} (median)")
    if results["lockstep"] and results["realtime"]:
        ratios = []
        for i, ax in enumerate(AXES):
            key = ax + ("_m" if i < 3 else "_rad")
            l = statistics.median(r["rmse_vs_ground_truth"][key] for r in results["lockstep"])
            t = statistics.median(r["rmse_vs_ground_truth"][key] for r in results["realtime"])
            ratios.append(f"{ax} {t / l:.2f}")
        print("real-time / lockstep RMSE (median RMSE per mode): " + ", ".join(ratios))


if __name__ == "__main__":
    main()
