#!/usr/bin/python3
"""Is a silent supervisor the program's or the host's? (docs/measurements/realtime.md)

Runs N real-time sessions of the combined trajectory (1 period, seeds 1..N) and, beside them,
samples every CPU's steal time from /proc/stat about once a millisecond: the time the
hypervisor did not run that virtual CPU although the guest had work for it. After each
session it reads the supervisor's LegSetpoint publish times from the recording and lists
every gap between two consecutive setpoints longer than --gap-ms, with the steal each CPU
accrued over that gap (a vCPU's steal is booked at its first tick after it runs again, so the
window ends 20 ms after the gap). A gap that matches the steal of the supervisor's CPU is the
host's; a gap without steal is the program's, the guest kernel's or a host stall that is not booked
as steal. To tell these apart, a probe per CPU (a SCHED_FIFO 99 process pinned to that CPU,
waking every millisecond) records every wake-up later than 5 ms: nothing in the guest's user
space can hold it off, so a probe as late as the gap on the supervisor's CPU means that CPU
stopped as a whole.

    /work/nsrun NS /usr/bin/python3 bench/session/cpu_stalls.py --build build --runs 20
    /work/nsrun NS /usr/bin/python3 bench/session/cpu_stalls.py --build build --runs 20 --bridge

Steal is counted in USER_HZ ticks (10 ms on Debian's kernels): a gap shorter than 10 ms
cannot be matched. Run it as root (the launcher asks for SCHED_FIFO) inside a network
namespace of its own.
"""
import argparse
import bisect
import csv
import os
import re
import shutil
import subprocess
import sys
import tempfile
import threading
import time

USER_HZ = os.sysconf("SC_CLK_TCK")


class StealSampler(threading.Thread):
    """(CLOCK_REALTIME ns, [steal seconds per CPU]) about once a millisecond."""

    def __init__(self):
        super().__init__(daemon=True)
        self.times, self.steal = [], []
        self.stop = threading.Event()

    def read(self):
        per_cpu = []
        with open("/proc/stat") as f:
            for line in f:
                if line.startswith("cpu") and line[3].isdigit():
                    per_cpu.append(int(line.split()[8]) / USER_HZ)
        return per_cpu

    def run(self):
        while not self.stop.is_set():
            now, steal = time.time_ns(), self.read()
            self.steal.append(steal)  # before the time: `between` indexes by the times
            self.times.append(now)
            time.sleep(0.001)

    def between(self, t0_ns, t1_ns):
        """Steal seconds per CPU booked in [t0, t1]."""
        times = self.times[:len(self.steal)]
        i = max(0, bisect.bisect_right(times, t0_ns) - 1)
        j = min(len(times) - 1, bisect.bisect_left(times, t1_ns))
        return [b - a for a, b in zip(self.steal[i], self.steal[j])]


PROBE = r"""
import os, sys, time
os.sched_setaffinity(0, {int(sys.argv[1])})
os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(99))
last = time.monotonic_ns()
while True:
    time.sleep(0.001)
    now = time.monotonic_ns()
    if now - last > 5_000_000:
        print(time.time_ns(), now - last, flush=True)
    last = now
"""


class LatencyProbe:
    """A SCHED_FIFO 99 process pinned to one CPU: (end CLOCK_REALTIME ns, gap ns) of late wake-ups."""

    def __init__(self, cpu):
        self.events = []
        self.proc = subprocess.Popen([sys.executable, "-c", PROBE, str(cpu)], stdout=subprocess.PIPE,
                                     text=True)
        self.reader = threading.Thread(target=self.read, daemon=True)
        self.reader.start()

    def read(self):
        for line in self.proc.stdout:
            end, gap = (int(x) for x in line.split())
            self.events.append((end, gap))

    def largest(self, t0_ns, t1_ns):
        """The longest late wake-up overlapping [t0, t1], in ms."""
        return max((gap / 1e6 for end, gap in list(self.events) if end >= t0_ns and end - gap <= t1_ns),
                   default=0.0)

    def close(self):
        self.proc.terminate()
        self.proc.wait()


def supervisor_cpu(out):
    try:
        for line in open(os.path.join(out, "supervisor.log"), errors="replace"):
            m = re.search(r"CPU affinity: (\d+)", line)
            if m:
                return int(m.group(1))
    except OSError:
        pass
    return None


def setpoint_gaps(recorder, out, gap_ms):
    """[(start_ns, end_ns, tick_before, tick_after)] between consecutive leg-1 setpoints."""
    csv_dir = os.path.join(out, "csv")
    subprocess.run([recorder, "export", os.path.join(out, "session.mcap"), "--out-dir", csv_dir,
                    "--topics", "hexa_LegSetpoint"], stdout=subprocess.DEVNULL,
                   stderr=subprocess.DEVNULL, check=False)
    path = os.path.join(csv_dir, "hexa_LegSetpoint.csv")
    if not os.path.exists(path):
        return None
    rows = []
    with open(path) as f:
        r = csv.reader(f)
        head = next(r)
        pub, leg, tick = (head.index(h) for h in ("publish_time_ns [ns]", "leg_id [1]", "header.tick [1]"))
        for row in r:
            if row[leg] == "1":
                rows.append((int(row[pub]), int(row[tick])))
    rows.sort()
    return [(a[0], b[0], a[1], b[1]) for a, b in zip(rows, rows[1:]) if b[0] - a[0] > gap_ms * 1e6]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default="build")
    ap.add_argument("--runs", type=int, default=20)
    ap.add_argument("--gap-ms", type=float, default=15.0, help="list setpoint gaps longer than this")
    ap.add_argument("--bridge", action="store_true", help="run each session with the Foxglove bridge")
    ap.add_argument("--domain", type=int, default=94)
    args = ap.parse_args()
    build = os.path.abspath(args.build)
    session = os.path.join(build, "deploy", "hexa_session")
    recorder = os.path.join(build, "services", "recorder", "hexa_recorder")
    for exe in (session, recorder):
        if not os.access(exe, os.X_OK):
            sys.exit(f"error: no {exe} (build it first)")
    root = tempfile.mkdtemp(prefix="cpu_stalls.")
    sampler = StealSampler()
    sampler.start()
    probes = [LatencyProbe(cpu) for cpu in sorted(os.sched_getaffinity(0))]
    print(f"# {time.strftime('%Y-%m-%d %H:%M:%S', time.gmtime())} UTC, {args.runs} runs"
          f"{' with the bridge' if args.bridge else ''}, setpoint gaps > {args.gap_ms} ms, steal in "
          f"units of {1000 // USER_HZ} ms")
    print("run exit sup_cpu steal_ms_per_cpu(session) | gap: ticks, ms, steal ms per CPU, "
          "longest FIFO-99 probe wake-up ms per CPU over the gap")
    total_gaps = host_gaps = stopped_gaps = 0
    try:
        for i in range(1, args.runs + 1):
            out = os.path.join(root, f"seed{i}")
            argv = [session, "--mode", "realtime", "--trajectory", "combined", "--periods", "1",
                    "--seed", str(i), "--domain", str(args.domain), "--out", out, "--hold-timeout", "1"]
            if args.bridge:
                argv += ["--bridge", "--bridge-port", "0"]
            t0 = time.time_ns()
            with open(os.path.join(root, "console.log"), "w") as console:
                rc = subprocess.call(argv, stdout=console, stderr=subprocess.STDOUT)
            t1 = time.time_ns()
            cpu = supervisor_cpu(out)
            whole = sampler.between(t0, t1)
            gaps = setpoint_gaps(recorder, out, args.gap_ms)
            line = f"{i:3d} {rc:4d} {cpu if cpu is not None else '-':>7} " + \
                   "/".join(f"{s * 1e3:.0f}" for s in whole)
            if gaps is None:
                line += " | no recording"
            for g0, g1, ta, tb in gaps or []:
                steal = sampler.between(g0, g1 + 20_000_000)
                total_gaps += 1
                if cpu is not None and cpu < len(steal) and steal[cpu] * 1e9 >= 0.5 * (g1 - g0):
                    host_gaps += 1
                probe = [p.largest(g0, g1) for p in probes]
                if cpu is not None and cpu < len(probe) and probe[cpu] >= 0.5 * (g1 - g0) / 1e6:
                    stopped_gaps += 1
                line += (f" | {ta}->{tb}, {(g1 - g0) / 1e6:.1f} ms, steal "
                         + "/".join(f"{s * 1e3:.0f}" for s in steal) + ", probe "
                         + "/".join(f"{x:.1f}" for x in probe))
            print(line, flush=True)
            if rc == 0:
                shutil.rmtree(out, ignore_errors=True)
    finally:
        sampler.stop.set()
        for p in probes:
            p.close()
    print(f"{total_gaps} gaps over {args.gap_ms} ms; {host_gaps} with steal on the supervisor's CPU "
          f"of at least half the gap; {stopped_gaps} with the supervisor CPU's FIFO-99 probe late by "
          f"at least half the gap; sessions kept (failed ones) in {root}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
