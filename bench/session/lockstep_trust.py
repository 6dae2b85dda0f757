#!/usr/bin/python3
"""Lockstep under load and stalls (docs/liveliness.md, "Liveliness in lockstep"): N lockstep
sessions of the combined trajectory, each compared bit for bit with a reference session, with
optionally `stress-ng --cpu K` beside them and one process stopped (SIGSTOP) for a while.

    /usr/bin/python3 bench/session/lockstep_trust.py --runs 20 --stress 4
    /usr/bin/python3 bench/session/lockstep_trust.py --runs 5 --stress 4 --secure
    /usr/bin/python3 bench/session/lockstep_trust.py --runs 10 --stop leg3 --stop-s 0.6 --at startup
    /usr/bin/python3 bench/session/lockstep_trust.py --runs 10 --stop supervisor --stop-s 3 --at midrun

The reference is a session this script runs first, without stress and without a stop
(or --reference DIR, a session directory of an earlier run). "Identical" compares the plant's
GroundTruth of every tick (state, applied valve voltages, command ages; every field but the
times) as exported by `hexa_recorder export`: the same simulated run, bit for bit.

--stop NAME stops that process of the session (leg1..leg6, leg3_standby, supervisor, recorder,
plant) with SIGSTOP for --stop-s seconds, then SIGCONT: --at startup as soon as the process
exists, --at running as soon as it logs that it runs (its DDS entities exist and have matched;
the plant may not tick yet), --at midrun 0.5 s after the plant logged that it ticks.
Each run reports the exit code, wall time, time to the first tick, whether it is identical,
and for a session that did not complete the plant's and the launcher's error lines.
Run it inside a network namespace of its own (/work/nsrun NAME ...), or as root.
"""
import argparse
import csv
import hashlib
import os
import re
import shutil
import signal
import subprocess
import sys
import time


def load():
    return " ".join(open("/proc/loadavg").read().split()[:3])


def children(pid):
    """Child pids of `pid` with their command lines (/proc/PID/task/*/children: no scan)."""
    out = []
    try:
        tids = os.listdir("/proc/%d/task" % pid)
    except OSError:
        return out
    for tid in tids:
        try:
            kids = open("/proc/%d/task/%s/children" % (pid, tid)).read().split()
        except OSError:
            continue
        for k in kids:
            try:
                cmd = open("/proc/%s/cmdline" % k, "rb").read().split(b"\0")
                out.append((int(k), [c.decode() for c in cmd if c]))
            except OSError:
                continue
    return out


def find_process(session_pid, name):
    """The pid of the session's child called `name` (as hexa_session names it), or None."""
    for pid, cmd in children(session_pid):
        if not cmd:
            continue
        exe = os.path.basename(cmd[0])
        if name == "supervisor" and exe == "hexa_task_space":
            return pid
        if name == "plant" and exe == "hexa_plant_sim":
            return pid
        if name == "recorder" and exe == "hexa_recorder":
            return pid
        if name.startswith("leg") and exe == "hexa_leg_ctrl":
            leg = name[3]
            standby = name.endswith("_standby")
            if "--leg" in cmd and cmd[cmd.index("--leg") + 1] == leg and ("--standby" in cmd) == standby:
                return pid
    return None


def running_line(out_dir, name):
    """The log file and the line by which process `name` says it runs."""
    if name == "recorder":
        return os.path.join(out_dir, "recorder.console.log"), "record: domain"
    return os.path.join(out_dir, name + ".log"), name + " running"


def fingerprint(build, out_dir):
    """One sha256 per recorded GroundTruth tick (times and sequence numbers left out), in tick
    order; None if there is no recording."""
    rec = os.path.join(out_dir, "session.mcap")
    if not os.path.exists(rec):
        rec = os.path.join(out_dir, "session.recovered.mcap")
    if not os.path.exists(rec):
        return None
    exp = os.path.join(out_dir, "export")
    shutil.rmtree(exp, ignore_errors=True)
    r = subprocess.run([os.path.join(build, "services/recorder/hexa_recorder"), "export", rec,
                        "--out-dir", exp, "--topics", "*GroundTruth*"],
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    # One CSV per topic (the export also writes a README.txt describing the columns).
    files = ([f for f in os.listdir(exp) if f.endswith(".csv")]
             if r.returncode == 0 and os.path.isdir(exp) else [])
    if len(files) != 1:
        return None
    rows = []
    with open(os.path.join(exp, files[0])) as f:
        reader = csv.reader(f)
        header = next(reader)
        names = [c.split(" [")[0] for c in header]  # "name [unit]"
        keep = [i for i, c in enumerate(names)
                if not (c in ("log_time_ns", "publish_time_ns", "sequence") or "time_ns" in c)]
        for row in reader:
            rows.append(hashlib.sha256(",".join(row[i] for i in keep).encode()).hexdigest())
    shutil.rmtree(exp, ignore_errors=True)
    return rows


def compare(ref, run):
    """(identical, ticks compared). A session ends when the supervisor has left after its last
    setpoint: the plant may step up to 6 ticks more or less (docs/architecture.md), so the
    common ticks are compared and the lengths may differ by that much only."""
    if ref is None or run is None:
        return False, 0
    n = min(len(ref), len(run))
    return ref[:n] == run[:n] and abs(len(ref) - len(run)) <= 6 and n > 1000, n


def error_lines(out_dir):
    lines = []
    for name in ("session.log", "plant.log"):
        path = os.path.join(out_dir, name)
        if os.path.exists(path):
            lines += [l.rstrip() for l in open(path, errors="replace")
                      if re.search(r"\] (error|critical) ", l)]
    return lines[:6]


def first_tick_s(out_dir):
    """Wall seconds from the session start to the plant's first tick (from the logs)."""
    def stamp(path, needle):
        if not os.path.exists(path):
            return None
        for l in open(path, errors="replace"):
            if needle in l:
                m = re.match(r"\[?(\d+)-(\d+)-(\d+) (\d+):(\d+):(\d+)\.(\d+)", l)
                if m:
                    return (int(m.group(4)) * 3600 + int(m.group(5)) * 60 + int(m.group(6)) +
                            int(m.group(7)) / 10 ** len(m.group(7)))
        return None
    t0 = stamp(os.path.join(out_dir, "session.log"), "session:")
    t1 = stamp(os.path.join(out_dir, "plant.log"), "ticking in")
    return None if t0 is None or t1 is None else t1 - t0


def run_one(args, out_dir, domain, stop):
    shutil.rmtree(out_dir, ignore_errors=True)
    cmd = [os.path.join(args.build, "deploy/hexa_session"), "--trajectory", "combined",
           "--periods", str(args.periods), "--seed", str(args.seed), "--out", out_dir,
           "--domain", str(domain), "--timeout", str(args.timeout)] + args.session_arg
    if args.secure:
        cmd.append("--secure")
    t0 = time.time()
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    stopped = None
    if stop:
        pid = None
        deadline = time.time() + 30
        while pid is None and time.time() < deadline and proc.poll() is None:
            pid = find_process(proc.pid, args.stop)
            if pid is None:
                time.sleep(0.001)
        if pid is not None and args.at == "running":
            # The process has its DDS entities and says it runs (a leg: matched; the plant may
            # or may not tick yet): a lease started now lapses before the writer's first write.
            log, needle = running_line(out_dir, args.stop)
            while time.time() < deadline and proc.poll() is None:
                if os.path.exists(log) and needle in open(log, errors="replace").read():
                    break
                time.sleep(0.001)
        if pid is not None and args.at == "midrun":
            plant_log = os.path.join(out_dir, "plant.log")
            while time.time() < deadline + 60 and proc.poll() is None:
                if os.path.exists(plant_log) and "ticking in" in open(plant_log, errors="replace").read():
                    break
                time.sleep(0.02)
            time.sleep(0.5)
        if pid is not None and proc.poll() is None:
            try:
                os.kill(pid, signal.SIGSTOP)
                stopped = time.time() - t0
                time.sleep(args.stop_s)
            finally:
                os.kill(pid, signal.SIGCONT)
    rc = proc.wait()
    wall = time.time() - t0
    return rc, wall, fingerprint(args.build, out_dir), stopped


def main():
    here = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default=os.path.join(here, "build"))
    ap.add_argument("--runs", type=int, default=20)
    ap.add_argument("--periods", type=int, default=1)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--timeout", type=float, default=300)
    ap.add_argument("--stress", type=int, default=0, help="stress-ng --cpu K beside the runs")
    ap.add_argument("--secure", action="store_true", help="hexa_session --secure")
    ap.add_argument("--stop", default="", help="process to stop (leg3, supervisor, recorder, ...)")
    ap.add_argument("--stop-s", type=float, default=0.6)
    ap.add_argument("--at", choices=["startup", "running", "midrun"], default="midrun")
    ap.add_argument("--reference", default="", help="session directory to compare with")
    ap.add_argument("--session-arg", action="append", default=[],
                    help="one more argument for hexa_session (repeatable)")
    ap.add_argument("--out", default=os.path.join(here, "out", "lockstep_trust"))
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    domain = 100 + os.getpid() % 100
    if a.reference:
        ref = fingerprint(a.build, a.reference)
        ref_from = a.reference
    else:
        ref_dir = os.path.join(a.out, "reference")
        rc, wall, ref, _ = run_one(a, ref_dir, domain, False)
        ref_from = "quiet run (exit %d, %.1f s)" % (rc, wall)
        if rc != 0 or ref is None:
            sys.exit("lockstep_trust: the reference session failed (exit %d): %s" %
                     (rc, "\n".join(error_lines(ref_dir))))
    print("lockstep_trust: %d runs, stress-ng --cpu %d, %s%s, reference %s (%d ticks), load %s, %s" % (
        a.runs, a.stress, "secure, " if a.secure else "",
        "stop %s %.1f s at %s" % (a.stop, a.stop_s, a.at) if a.stop else "no stop",
        ref_from, len(ref or []), load(), time.strftime("%Y-%m-%d %H:%M:%S UTC", time.gmtime())), flush=True)
    stress = None
    if a.stress > 0:
        stress = subprocess.Popen(["stress-ng", "--cpu", str(a.stress), "--quiet"],
                                  stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                  start_new_session=True)
        time.sleep(1)
    completed = identical = 0
    try:
        for k in range(a.runs):
            out_dir = os.path.join(a.out, "run%02d" % k)
            before = load()
            rc, wall, fp, stopped = run_one(a, out_dir, domain, bool(a.stop))
            same, rows = compare(ref, fp)
            completed += rc == 0
            identical += rc == 0 and same
            ft = first_tick_s(out_dir)
            print("run %2d: exit %d  %6.1f s wall  first tick after %s  identical %s (%d ticks compared)%s  load %s" % (
                k, rc, wall, "%.1f s" % ft if ft is not None else "-", "yes" if same else "NO",
                rows, "  stopped at %.2f s" % stopped if stopped is not None else "", before),
                flush=True)
            if rc != 0:
                for l in error_lines(out_dir):
                    print("        " + l[:300], flush=True)
    finally:
        if stress is not None:
            os.killpg(stress.pid, signal.SIGTERM)
            stress.wait()
    print("lockstep_trust: %d of %d completed, %d of %d completed and bit-identical to the reference"
          % (completed, a.runs, identical, a.runs))
    return 0 if identical == a.runs else 1


if __name__ == "__main__":
    sys.exit(main())
