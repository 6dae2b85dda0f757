#!/usr/bin/python3
"""Does real time complete every session (docs/measurements/realtime.md)?
Runs N real-time sessions of the combined trajectory (1 period, seeds 1..N) one after the other,
optionally with `stress-ng --cpu K` beside them at normal priority, and lists every run:

    /usr/bin/python3 bench/session/rt_completion.py --build build --runs 50
    /usr/bin/python3 bench/session/rt_completion.py --build build --runs 50 --stress 2

Per run: the session's exit code (0 completed, 3 held, others in docs/exit_codes.md), its wall
time, the plant's ticks, late ticks (the sum over legs of ticks whose command came late),
schedule slips and the time slipped, the longest control round trip, and for a run that did not
complete the supervisor's hold line. The last line counts completions. Run it as root (the
launcher asks for SCHED_FIFO) inside a network namespace of its own (/work/nsrun NAME ...).
"""
import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time


def load():
    return " ".join(open("/proc/loadavg").read().split()[:3])


def hold_line(out):
    try:
        for line in open(os.path.join(out, "supervisor.log"), errors="replace"):
            if "HOLD" in line and ("error" in line or "warn" in line):
                return line.strip()[:200]
    except OSError:
        pass
    return ""


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default="build", help="build directory (its deploy/hexa_session)")
    ap.add_argument("--runs", type=int, default=50)
    ap.add_argument("--stress", type=int, default=0, help="stress-ng --cpu K beside the runs (0: none)")
    ap.add_argument("--domain", type=int, default=93)
    ap.add_argument("--keep", action="store_true", help="keep every session directory")
    args = ap.parse_args()
    session = os.path.join(os.path.abspath(args.build), "deploy", "hexa_session")
    if not os.access(session, os.X_OK):
        sys.exit(f"error: no {session} (build it first)")
    if args.stress and not shutil.which("stress-ng"):
        sys.exit("error: --stress needs stress-ng (apt-get install stress-ng)")
    root = tempfile.mkdtemp(prefix="rt_completion.")
    stress = None
    if args.stress:
        stress = subprocess.Popen(["stress-ng", "--cpu", str(args.stress), "--timeout", "0"],
                                  stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        time.sleep(1.0)
    print(f"# {time.strftime('%Y-%m-%d %H:%M:%S', time.gmtime())} UTC, {args.runs} runs, "
          f"stress-ng --cpu {args.stress}" if args.stress else
          f"# {time.strftime('%Y-%m-%d %H:%M:%S', time.gmtime())} UTC, {args.runs} runs, no load beside")
    print("run seed exit wall_s ticks late_ticks slips slipped_s rtt_max_ms load1_before hold")
    completed = 0
    try:
        for i in range(1, args.runs + 1):
            out = os.path.join(root, f"seed{i}")
            before = load().split()[0]
            t0 = time.monotonic()
            with open(os.path.join(root, "console.log"), "w") as console:
                rc = subprocess.call([session, "--mode", "realtime", "--trajectory", "combined",
                                      "--periods", "1", "--seed", str(i), "--domain", str(args.domain),
                                      "--out", out, "--hold-timeout", "1"], stdout=console, stderr=subprocess.STDOUT)
            wall = time.monotonic() - t0
            try:
                p = json.load(open(os.path.join(out, "plant.json")))
                late = sum(leg.get("late_ticks", 0) for leg in p.get("legs", []))
                rtt = p.get("control_round_trip_s", {}).get("max", float("nan")) * 1e3
                row = (p.get("ticks", 0), late, p.get("schedule_slips", 0), p.get("slipped_s", 0.0), rtt)
            except (OSError, ValueError):
                row = (0, -1, -1, float("nan"), float("nan"))
            completed += rc == 0
            print(f"{i:3d} {i:4d} {rc:4d} {wall:6.1f} {row[0]:6d} {row[1]:6d} {row[2]:5d} {row[3]:8.4f} "
                  f"{row[4]:8.2f} {before:>6} {hold_line(out) if rc else ''}", flush=True)
            if rc == 0 and not args.keep:
                shutil.rmtree(out, ignore_errors=True)
    finally:
        if stress:
            stress.terminate()
            stress.wait()
    print(f"completed {completed} of {args.runs}" + (f"; kept in {root}" if completed < args.runs or args.keep else ""))
    if completed == args.runs and not args.keep:
        shutil.rmtree(root, ignore_errors=True)
    return 0 if completed == args.runs else 1


if __name__ == "__main__":
    sys.exit(main())
