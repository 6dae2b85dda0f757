#!/usr/bin/python3
"""How often and how long each process of a real-time session waits for a CPU (docs/measurements/
faults_under_load.md, "Scheduling delays in real time"): N real-time sessions (combined trajectory, 1 period,
seeds 1..N), each traced with `perf sched record -a`, optionally with `stress-ng --cpu K` beside.

    /usr/bin/python3 bench/session/rt_sched_delays.py --runs 5
    /usr/bin/python3 bench/session/rt_sched_delays.py --runs 5 --stress 2

Per run and per process (plant, leg1..leg6, supervisor, recorder) it prints the scheduling
delays of its threads from `perf sched timehist` (the time a thread was runnable, woken or
preempted, before it ran): how many exceeded 1, 5 and 20 ms, the longest with its thread and
its time from the session start. Once per run it prints the scheduling class and priority of
every thread of the session's processes, read from /proc while the plant ticks (which threads
really run at SCHED_FIFO: the main threads, Cyclone's receive and delivery threads). The
plant's slips (wake-ups more than 2 ms late), the session's exit code and the load average
before the run complete the line. Run as root (SCHED_FIFO, perf) in a network namespace of its
own (/work/nsrun NAME ...).
"""
import argparse
import collections
import os
import re
import signal
import subprocess
import sys
import time

POLICY = {0: "OTHER", 1: "FIFO", 2: "RR", 3: "BATCH", 5: "IDLE", 6: "DEADLINE"}
THRESHOLDS_MS = (1.0, 5.0, 20.0)


def load():
    return " ".join(open("/proc/loadavg").read().split()[:3])


def session_processes(session_pid):
    """{pid: name} of the session's children, named as hexa_session names them."""
    out = {}
    try:
        tids = os.listdir("/proc/%d/task" % session_pid)
    except OSError:
        return out
    for tid in tids:
        try:
            kids = open("/proc/%d/task/%s/children" % (session_pid, tid)).read().split()
        except OSError:
            continue
        for k in kids:
            try:
                cmd = [c.decode() for c in open("/proc/%s/cmdline" % k, "rb").read().split(b"\0") if c]
            except OSError:
                continue
            if not cmd:
                continue
            exe = os.path.basename(cmd[0])
            name = {"hexa_plant_sim": "plant", "hexa_task_space": "supervisor",
                    "hexa_recorder": "recorder", "hexa_bridge": "bridge"}.get(exe)
            if exe == "hexa_leg_ctrl" and "--leg" in cmd:
                name = "leg" + cmd[cmd.index("--leg") + 1] + ("_standby" if "--standby" in cmd else "")
            if name:
                out[int(k)] = name
    return out


def thread_classes(pids):
    """{name: [(thread, class, priority)]} read from /proc/PID/task/TID/stat."""
    out = {}
    for pid, name in pids.items():
        rows = []
        try:
            tids = sorted(os.listdir("/proc/%d/task" % pid), key=int)
        except OSError:
            continue
        for tid in tids:
            try:
                stat = open("/proc/%d/task/%s/stat" % (pid, tid)).read()
            except OSError:
                continue
            comm = stat[stat.index("(") + 1:stat.rindex(")")]
            fields = stat[stat.rindex(")") + 2:].split()
            # fields[0] is field 3 (state): rt_priority is field 40, policy field 41.
            rows.append((comm, POLICY.get(int(fields[38]), fields[38]), int(fields[37])))
        out[name] = rows
    return out


LINE = re.compile(r"^\s*(\d+\.\d+)\s+\[(\d+)\]\s+(.*?)\[(\d+)(?:/(\d+))?\]\s+"
                  r"(\d+\.\d+)\s+(\d+\.\d+)\s+(\d+\.\d+)")


def delays(perf_data, pids, t0_mono, window):
    """Per process name: (counts over each threshold, max delay ms, thread, at s, tev max ms),
    for the delays that ended within `window` (monotonic s: the plant's ticking); Cyclone's
    timed-event thread (tev, normal scheduling by design) only in its own maximum."""
    r = subprocess.run(["perf", "sched", "timehist", "-i", perf_data], capture_output=True,
                       text=True)
    per = {}
    for line in r.stdout.splitlines():
        m = LINE.match(line)
        if not m:
            continue
        tid = int(m.group(4))
        pid = int(m.group(5)) if m.group(5) else tid
        if pid not in pids:
            continue
        at = float(m.group(1))
        if not window[0] <= at <= window[1]:
            continue
        name = pids[pid]
        d_ms = float(m.group(7))
        e = per.setdefault(name, [[0] * len(THRESHOLDS_MS), 0.0, "", 0.0, 0.0])
        if m.group(3).strip() == "tev":
            e[4] = max(e[4], d_ms)
            continue
        for i, th in enumerate(THRESHOLDS_MS):
            if d_ms > th:
                e[0][i] += 1
        if d_ms > e[1]:
            e[1] = d_ms
            e[2] = m.group(3).strip()
            e[3] = at - t0_mono
    return per


def plant_slips(out_dir):
    path = os.path.join(out_dir, "plant.log")
    if not os.path.exists(path):
        return 0, []
    text = open(path, errors="replace").read()
    slips = len(re.findall(r"the plant woke [\d.]+ ms late", text))
    faults = [l for l in text.splitlines() if re.search(r"\] (error|critical) ", l)][:3]
    return slips, faults


def run_one(a, k, domain):
    out_dir = os.path.join(a.out, "run%02d" % k)
    subprocess.run(["rm", "-rf", out_dir])
    os.makedirs(out_dir)
    perf_data = os.path.join(out_dir, "sched.data")
    perf = subprocess.Popen(["perf", "sched", "record", "-k", "CLOCK_MONOTONIC", "-a", "-o", perf_data],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    time.sleep(1.0)  # perf is recording
    t0_mono = time.clock_gettime(time.CLOCK_MONOTONIC)
    before = load()
    cmd = [os.path.join(a.build, "deploy/hexa_session"), "--mode", "realtime",
           "--trajectory", "combined", "--periods", "1", "--seed", str(k + 1),
           "--out", os.path.join(out_dir, "session"), "--domain", str(domain)] + a.session_arg
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    pids, classes = {}, {}
    plant_log = os.path.join(out_dir, "session", "plant.log")
    window = [float("inf"), float("inf")]  # the plant ticks: from its first tick to its stop
    while proc.poll() is None:
        pids.update(session_processes(proc.pid))
        text = open(plant_log, errors="replace").read() if os.path.exists(plant_log) else ""
        now = time.clock_gettime(time.CLOCK_MONOTONIC)
        if window[0] == float("inf") and "ticking in" in text:
            window[0] = now
        if window[1] == float("inf") and "stopped at tick" in text:
            window[1] = now
        if not classes and now > window[0] + 0.5:
            classes = thread_classes(session_processes(proc.pid))
        time.sleep(0.02)
    rc = proc.returncode
    perf.send_signal(signal.SIGINT)
    perf.wait()
    per = delays(perf_data, pids, t0_mono, window)
    os.remove(perf_data)
    slips, faults = plant_slips(os.path.join(out_dir, "session"))
    return rc, before, per, classes, slips, faults


def main():
    here = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default=os.path.join(here, "build"))
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--stress", type=int, default=0, help="stress-ng --cpu K beside the runs")
    ap.add_argument("--session-arg", action="append", default=[],
                    help="one more argument for hexa_session (repeatable)")
    ap.add_argument("--out", default=os.path.join(here, "out", "rt_sched_delays"))
    a = ap.parse_args()
    if os.geteuid() != 0:
        sys.exit("rt_sched_delays: run as root (SCHED_FIFO and perf need it)")
    os.makedirs(a.out, exist_ok=True)
    domain = 100 + os.getpid() % 100
    print("rt_sched_delays: %d real-time runs, stress-ng --cpu %d, %s, load %s" % (
        a.runs, a.stress, time.strftime("%Y-%m-%d %H:%M:%S UTC", time.gmtime()), load()), flush=True)
    stress = None
    if a.stress > 0:
        stress = subprocess.Popen(["stress-ng", "--cpu", str(a.stress), "--quiet"],
                                  stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                  start_new_session=True)
        time.sleep(1)
    worst = collections.defaultdict(lambda: [[0] * len(THRESHOLDS_MS), 0.0])
    completed = 0
    try:
        for k in range(a.runs):
            rc, before, per, classes, slips, faults = run_one(a, k, domain)
            completed += rc == 0
            print("run %2d: exit %d, plant slips %d, load %s" % (k, rc, slips, before), flush=True)
            for f in faults:
                print("        " + f[:240], flush=True)
            for name in sorted(per):
                counts, mx, thread, at, tev = per[name]
                w = worst[name]
                w[0] = [x + y for x, y in zip(w[0], counts)]
                w[1] = max(w[1], mx)
                print("        %-11s delays >1/>5/>20 ms: %5d %4d %3d   longest %6.1f ms (%s at %.1f s); "
                      "tev longest %.1f ms" % (name, counts[0], counts[1], counts[2], mx, thread, at, tev),
                      flush=True)
            if k == 0 or a.runs == 1:
                for name in sorted(classes):
                    text = ", ".join("%s %s%s" % (c, p, " %d" % pr if pr else "")
                                     for c, p, pr in classes[name])
                    print("        threads of %s: %s" % (name, text), flush=True)
    finally:
        if stress is not None:
            os.killpg(stress.pid, signal.SIGTERM)
    print("summary: %d of %d completed; per process, all runs: delays >1/>5/>20 ms, longest" % (
        completed, a.runs))
    for name in sorted(worst):
        c, mx = worst[name]
        print("  %-11s %6d %5d %4d   %6.1f ms" % (name, c[0], c[1], c[2], mx))


if __name__ == "__main__":
    main()
