#!/usr/bin/python3
"""The loop benchmark: the anchors and the whole system side by side, in one run.

Anchors (what this machine can do at all):
  cyclictest   1 kHz wake-ups of a SCHED_FIFO thread: median, max, share later than 0.5 ms;
  ddsperf      ping/pong round trip (waitset) over the project's loopback DDS config;
  fan-out      bench/loop/loop_fanout: the system's lockstep topology on the comm/ layer with no
               physics (a writer per leg partition, six answering processes, a supervisor
               every 5th tick, with and without a passive reliable recorder, WaitSet delivery):
               the naive way to build it.
The system (hexa_session, combined trajectory):
  lockstep     with and without the recorder: wall time per tick (mean; median and p99 from the
               plant's summary), simulated s per wall s, CPU of all processes per simulated s;
  real time    --rt-runs sessions with the recorder: completed or not, late ticks (the plant
               applied a command older than the sensor sample before it; command-age
               histogram in plant.json), control round trip median / p99, RMSE / lockstep RMSE.
Each figure is the median over --runs runs (real time: over the completed runs, all runs
listed), printed as a table with its ratio to its anchor and saved as JSON. --baseline-build
runs the same system rows with another build (e.g. the commit before) interleaved with this
one, so before and after are measured in the same minutes. --hog runs everything with a CPU
hog (stress-ng --cpu 1 at normal priority, pinned to CPU 0) beside it. --coupled-legs adds
the same system rows of --build with `hexa_session --coupled-legs` (the coupled leg feedback,
docs/controller.md), run interleaved with the decoupled ones and listed as build "coupled";
--variant NAME=ARGS does the same with any hexa_session arguments.

Every DDS process runs in a private network namespace (the script re-executes itself under
`unshare -n` when run as root), pinned to the loopback interface.

Usage: /usr/bin/python3 bench/loop/run_loop_bench.py [--build build] [--baseline-build DIR]
           [--runs 3] [--rt-runs 10] [--fanout-ticks 10000] [--hog] [--coupled-legs]
           [--variant NAME=ARGS ...]
           [--out out/loop-bench]
"""
import argparse
import contextlib
import json
import os
import re
import resource
import shutil
import signal
import statistics
import struct
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
DDS_CONFIG = os.path.join(HERE, "deploy", "cyclonedds-loopback.xml")
AXES = ["x", "y", "z", "roll", "pitch", "yaw"]


def log(msg):
    sys.stderr.write(msg + "\n")
    sys.stderr.flush()


def med(values):
    values = [v for v in values if v is not None]
    return statistics.median(values) if values else None


def loadavg():
    with open("/proc/loadavg") as f:
        return [float(x) for x in f.read().split()[:3]]


def children_cpu():
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def udp_datagrams():
    with open("/proc/net/snmp") as f:
        rows = [l.split() for l in f if l.startswith("Udp:")]
    head, vals = rows[0], rows[1]
    return int(vals[head.index("OutDatagrams")])


# ------------------------------------------------------------------------------ anchors

@contextlib.contextmanager
def cpu_latency_limit(latency_us):
    """Holds the kernel's CPU wake-up latency limit (/dev/cpu_dma_latency) at latency_us while
    the block runs, as the system's services do (--cpu-latency-us), so that the anchors are
    measured under the same setting; None: the machine's own setting."""
    fd = None
    if latency_us is not None:
        try:
            fd = os.open("/dev/cpu_dma_latency", os.O_WRONLY)
            os.write(fd, struct.pack("i", latency_us))
        except OSError as e:
            log(f"cannot hold /dev/cpu_dma_latency at {latency_us} us ({e}): anchors at the "
                "machine's setting")
    try:
        yield
    finally:
        if fd is not None:
            os.close(fd)


def run_cyclictest(loops):
    if shutil.which("cyclictest") is None:
        log("cyclictest not found (Debian package rt-tests): skipped")
        return None
    out = subprocess.run(["cyclictest", "-m", "-p", "80", "-i", "1000", "-l", str(loops), "-q",
                          "-h", "2000"], capture_output=True, text=True).stdout
    hist = {}
    for line in out.splitlines():
        m = re.match(r"^(\d{6})\s+(\d+)", line)
        if m:
            hist[int(m.group(1))] = int(m.group(2))
    overflow = re.search(r"# Histogram Overflows:\s+(\d+)", out)
    over = int(overflow.group(1)) if overflow else 0
    total = sum(hist.values()) + over
    maxm = re.search(r"# Max Latencies:\s+(\d+)", out)
    if total == 0:
        return None
    late = sum(c for us, c in hist.items() if us > 500) + over
    acc, median_us = 0, None
    for us in sorted(hist):
        acc += hist[us]
        if acc >= total / 2:
            median_us = us
            break
    return {"wakeups": total, "median_us": median_us,
            "max_us": int(maxm.group(1)) if maxm else None,
            "late_over_0_5ms_pct": 100.0 * late / total}


def run_ddsperf(seconds):
    env = dict(os.environ, CYCLONEDDS_URI="file://" + DDS_CONFIG)
    pong = subprocess.Popen(["ddsperf", "-D", str(seconds + 2), "pong", "waitset"], env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    time.sleep(0.3)
    out = subprocess.run(["ddsperf", "-D", str(seconds), "ping", "1kHz", "waitset"], env=env,
                         capture_output=True, text=True).stdout
    pong.wait()
    medians, p99s = [], []
    for line in out.splitlines()[2:]:  # skip the first second (discovery)
        m = re.search(r"50% ([\d.]+)us .* 99% ([\d.]+)us", line)
        if m:
            medians.append(float(m.group(1)))
            p99s.append(float(m.group(2)))
    if not medians:
        return None
    # ddsperf prints half the round trip.
    return {"round_trip_median_us": 2 * statistics.median(medians),
            "round_trip_p99_us": 2 * statistics.median(p99s)}


def run_fanout(build, ticks, recorder):
    exe = os.path.join(build, "bench", "loop", "loop_fanout")
    env = dict(os.environ, CYCLONEDDS_URI="file://" + DDS_CONFIG)
    base = ["--ticks", str(ticks), "--routing", "partition", "--delivery", "waitset"]
    if not recorder:
        base.append("--no-recorder")
    procs = []
    roles = ([["--role", "recorder"]] if recorder else []) + \
        [["--role", "leg", "--leg", str(l)] for l in range(1, 7)] + [["--role", "supervisor"]]
    d0 = udp_datagrams()
    for r in roles:
        procs.append(subprocess.Popen([exe] + r + base, env=env, stdout=subprocess.PIPE,
                                      stderr=subprocess.DEVNULL, text=True))
    plant = subprocess.run([exe, "--role", "plant"] + base, env=env, capture_output=True,
                           text=True, timeout=600)
    outs = [p.communicate(timeout=120)[0] for p in procs]
    datagrams = udp_datagrams() - d0
    rows = []
    for text in [plant.stdout] + outs:
        for line in text.splitlines():
            if line.startswith("{"):
                rows.append(json.loads(line))
    p = next((r for r in rows if r["role"] == "plant"), None)
    if p is None:
        return None
    cpu = sum(r["cpu_user_s"] + r["cpu_sys_s"] for r in rows)
    sim_s = p["ticks"] * 1e-3
    return {"tick_ms_median": p["tick_ms_median"], "tick_ms_p99": p["tick_ms_p99"],
            "tick_ms_mean": p["wall_s"] / p["ticks"] * 1e3,
            "cpu_s_per_sim_s": cpu / sim_s, "datagrams_per_tick": datagrams / p["ticks"]}


# ------------------------------------------------------------------------------ the system

def read_json(path):
    try:
        with open(path) as f:
            return json.load(f)
    except (OSError, ValueError):
        return None


def plant_loop_from_log(path):
    """(loop wall s, ticks) from plant.log: 'ticking in' -> 'stopped at tick N'."""
    t0 = t1 = ticks = None
    stamp = re.compile(r"^(\d{4}-\d\d-\d\d \d\d:\d\d:\d\d\.\d{3})")
    try:
        with open(path) as f:
            for line in f:
                m = stamp.match(line)
                if not m:
                    continue
                t = time.mktime(time.strptime(m.group(1)[:19], "%Y-%m-%d %H:%M:%S")) + \
                    float("0" + m.group(1)[19:])
                if "ticking in" in line:
                    t0 = t
                s = re.search(r"stopped at tick (\d+)", line)
                if s:
                    t1, ticks = t, int(s.group(1))
    except OSError:
        return None, None
    if t0 is None or t1 is None or not ticks:
        return None, None
    return t1 - t0, ticks


def run_session(build, out, mode, recorder, periods, seed, extra):
    shutil.rmtree(out, ignore_errors=True)
    cmd = [os.path.join(build, "deploy", "hexa_session"), "--trajectory", "combined",
           "--periods", str(periods), "--mode", mode, "--seed", str(seed), "--out", out,
           "--timeout", "900"] + extra
    if not recorder:
        cmd.append("--no-recorder")
    cpu0 = children_cpu()
    rc = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL).returncode
    cpu = children_cpu() - cpu0
    report = read_json(os.path.join(out, "report.json"))
    if report is not None:
        # The CPU of the report step is not the loop's: measure it again alone and subtract.
        cpu0 = children_cpu()
        subprocess.run([os.path.join(build, "services", "recorder", "hexa_recorder"), "report",
                        os.path.join(out, "session.mcap"), "--out", os.path.join(out, "rerun")],
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        cpu -= children_cpu() - cpu0
    wall, ticks = plant_loop_from_log(os.path.join(out, "plant.log"))
    summary = read_json(os.path.join(out, "plant.json"))
    processes = read_json(os.path.join(out, "processes.json"))
    r = {"exit_code": rc, "completed": rc == 0, "ticks": ticks, "loop_wall_s": wall,
         "cpu_s": cpu}
    if ticks:
        r["sim_time_s"] = ticks * 1e-3
        r["cpu_s_per_sim_s"] = cpu / (ticks * 1e-3)
        if wall:
            r["tick_ms_mean"] = wall / ticks * 1e3
            r["speed"] = ticks * 1e-3 / wall
    if summary:
        key = "tick_wall_s" if mode == "lockstep" else "wake_lateness_s"
        if key in summary:
            r["tick_ms_median"] = summary[key]["median"] * 1e3
            r["tick_ms_p99"] = summary[key]["p99"] * 1e3
        r["schedule_slips"] = summary.get("schedule_slips")
        r["slipped_ms"] = summary["slipped_s"] * 1e3 if "slipped_s" in summary else None
        legs = summary.get("legs", [])
        applied = sum(sum(l["command_age"]) for l in legs)
        late = sum(l["late_ticks"] for l in legs)
        if applied:
            r["late_ticks_pct"] = 100.0 * late / applied
            r["late_ticks_pct_worst_leg"] = max(
                100.0 * l["late_ticks"] / max(1, sum(l["command_age"])) for l in legs)
    if processes:
        r["processes"] = {p["name"]: p["cpu_user_s"] + p["cpu_system_s"]
                          for p in processes["processes"]}
    if report:
        rt = report.get("control_round_trip_latency_s", {})
        r["round_trip_median_us"] = rt.get("median", 0) * 1e6 if rt else None
        r["round_trip_p99_us"] = rt.get("p99", 0) * 1e6 if rt else None
        r["rmse"] = report.get("rmse_vs_ground_truth")
        r["faults"] = len(report.get("faults", []))
    return r


def rmse_ratio(rt_runs, ls_runs):
    out = {}
    for i, ax in enumerate(AXES):
        key = ax + ("_m" if i < 3 else "_rad")
        l = med([r["rmse"][key] for r in ls_runs if r.get("rmse")])
        t = med([r["rmse"][key] for r in rt_runs if r.get("rmse") and r["completed"]])
        out[ax] = t / l if l and t else None
    return out


def fmt(v, spec=".3f"):
    return "-" if v is None else format(v, spec)


def main():
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default=os.path.join(HERE, "build"))
    ap.add_argument("--baseline-build", help="another build (e.g. the previous commit) run "
                    "interleaved with --build for the system rows")
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--rt-runs", type=int, default=10)
    ap.add_argument("--periods", type=int, default=0, help="trajectory periods (0: default)")
    ap.add_argument("--fanout-ticks", type=int, default=10000)
    ap.add_argument("--cyclictest-loops", type=int, default=20000)
    ap.add_argument("--hog", action="store_true", help="a CPU hog on CPU 0 beside everything")
    ap.add_argument("--session-args", default="", help="extra hexa_session arguments "
                    "for --build (e.g. '--cpus-control 1')")
    ap.add_argument("--coupled-legs", action="store_true",
                    help="also run --build's system rows with hexa_session --coupled-legs, "
                         "interleaved (build \"coupled\")")
    ap.add_argument("--variant", action="append", default=[], metavar="NAME=ARGS",
                    help="also run --build's system rows with these extra hexa_session "
                         "arguments, interleaved, listed as build NAME (repeatable; e.g. "
                         "'no-auth=--insecure-commands' prices the command authentication)")
    ap.add_argument("--cpu-latency-us", default="0",
                    help="the CPU wake-up latency limit the system's services hold "
                    "(hexa_session --cpu-latency-us; default 0) and under which the anchors run; "
                    "'none': the machine's setting for both (a --baseline-build older than the "
                    "option holds none)")
    ap.add_argument("--out", default=os.path.join(HERE, "out", "loop-bench"))
    a = ap.parse_args()
    latency = None if a.cpu_latency_us == "none" else int(a.cpu_latency_us)
    variants = []
    for v in a.variant:
        name, sep, args = v.partition("=")
        if not sep or not name or name in ("new", "baseline", "coupled"):
            sys.exit(f"--variant {v!r}: expected NAME=ARGS with a NAME other than new, "
                     "baseline and coupled")
        variants.append((name, args.split()))

    if os.geteuid() == 0 and os.environ.get("HEXA_BENCH_NETNS") != "1":
        env = dict(os.environ, HEXA_BENCH_NETNS="1")
        cmd = ["unshare", "-n", "sh", "-c", 'ip link set lo up && exec "$0" "$@"',
               sys.executable] + sys.argv
        os.execvpe("unshare", cmd, env)
    if os.environ.get("HEXA_BENCH_NETNS") != "1":
        log("not root: running in this network namespace (DDS stays on lo by the config)")

    os.makedirs(a.out, exist_ok=True)
    hog = None
    if a.hog:
        if shutil.which("stress-ng") is None:
            sys.exit("--hog needs stress-ng (Debian package stress-ng)")
        hog = subprocess.Popen(["stress-ng", "--cpu", "1", "--taskset", "0", "--quiet"],
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        time.sleep(1)
    res = {"load_before": loadavg(), "hog": a.hog, "runs": a.runs, "rt_runs": a.rt_runs,
           "builds": {"new": a.build, "baseline": a.baseline_build,
                      "coupled": a.build if a.coupled_legs else None,
                      **{name: a.build for name, _ in variants}}}
    try:
        log("cyclictest ...")
        res["cyclictest"] = run_cyclictest(a.cyclictest_loops)  # holds 0 us itself
        res["cpu_latency_us"] = latency
        with cpu_latency_limit(latency):
            log("ddsperf ping/pong ...")
            res["ddsperf"] = med_dict([run_ddsperf(6) for _ in range(a.runs)])
            log("fan-out ...")
            res["fanout_rec"] = med_dict([run_fanout(a.build, a.fanout_ticks, True)
                                          for _ in range(a.runs)])
            res["fanout_norec"] = med_dict([run_fanout(a.build, a.fanout_ticks, False)
                                            for _ in range(a.runs)])
        if latency is not None:
            log("fan-out at the machine's own CPU latency setting (reference) ...")
            res["fanout_rec_machine"] = med_dict([run_fanout(a.build, a.fanout_ticks, True)
                                                  for _ in range(a.runs)])
        builds = [("new", a.build, a.session_args.split() +
                   (["--cpu-latency-us", "none"] if latency is None else
                    ["--cpu-latency-us", str(latency)]))]
        if a.coupled_legs:
            builds.append(("coupled", a.build, builds[0][2] + ["--coupled-legs"]))
        for name, args in variants:
            builds.append((name, a.build, builds[0][2] + args))
        if a.baseline_build:
            builds.append(("baseline", a.baseline_build, []))
        for name, _, _ in builds:
            res[name] = {"lockstep_rec": [], "lockstep_norec": [], "realtime": []}
        for k in range(a.runs):
            for name, build, extra in builds:
                for key, rec in [("lockstep_rec", True), ("lockstep_norec", False)]:
                    log(f"{name} lockstep {'with' if rec else 'without'} recorder, run {k} ...")
                    res[name][key].append(run_session(build, os.path.join(
                        a.out, f"{name}-{key}-{k}"), "lockstep", rec, a.periods, 1, extra))
        for k in range(a.rt_runs):
            for name, build, extra in builds:
                log(f"{name} real time, run {k} ...")
                res[name]["realtime"].append(run_session(build, os.path.join(
                    a.out, f"{name}-realtime-{k}"), "realtime", True, a.periods, 1, extra))
    finally:
        if hog is not None:
            hog.send_signal(signal.SIGINT)
            hog.wait()
    res["load_after"] = loadavg()
    with open(os.path.join(a.out, "loop_bench.json"), "w") as f:
        json.dump(res, f, indent=1)
    print_table(res, [b[0] for b in builds])


def med_dict(rows):
    rows = [r for r in rows if r]
    if not rows:
        return None
    return {k: med([r.get(k) for r in rows]) for k in rows[0]}


def summarize(runs):
    keys = ["tick_ms_mean", "tick_ms_median", "tick_ms_p99", "speed", "cpu_s_per_sim_s",
            "round_trip_median_us", "round_trip_p99_us", "late_ticks_pct",
            "late_ticks_pct_worst_leg"]
    done = [r for r in runs if r["completed"]] or runs
    return {k: med([r.get(k) for r in done]) for k in keys}


def print_table(res, builds):
    ct, dp, fr, fn = res["cyclictest"], res["ddsperf"], res["fanout_rec"], res["fanout_norec"]
    print(f"loop benchmark: load average before {res['load_before']}, after {res['load_after']}"
          f"{', CPU hog on CPU 0' if res['hog'] else ''}; medians of {res['runs']} runs "
          f"(real time: {res['rt_runs']} runs)")
    lat = res.get("cpu_latency_us")
    print("CPU wake-up latency limit (/dev/cpu_dma_latency) held by the system's services and "
          "during the anchors: " + ("none (the machine's setting)" if lat is None else
                                    f"{lat} us") + "; the baseline build holds none")
    print()
    print("| anchor | figure |")
    print("|---|---|")
    if ct:
        print(f"| cyclictest 1 kHz, SCHED_FIFO 80 | median {ct['median_us']} us, max "
              f"{ct['max_us']} us, {ct['late_over_0_5ms_pct']:.3f} % of {ct['wakeups']} "
              f"wake-ups > 0.5 ms late |")
    if dp:
        print(f"| ddsperf ping/pong (waitset) | round trip median {dp['round_trip_median_us']:.0f}"
              f" us, p99 {dp['round_trip_p99_us']:.0f} us |")
    for name, f in [("fan-out + recorder", fr), ("fan-out, no recorder", fn),
                    ("fan-out + recorder, machine's CPU latency setting (reference)",
                     res.get("fanout_rec_machine"))]:
        if f:
            print(f"| {name} | tick median {f['tick_ms_median']:.3f} ms, p99 "
                  f"{f['tick_ms_p99']:.3f} ms, mean {f['tick_ms_mean']:.3f} ms; "
                  f"{f['cpu_s_per_sim_s']:.3f} s CPU per simulated s; "
                  f"{f['datagrams_per_tick']:.1f} datagrams per tick |")
    print()
    print("| system | build | figure | value | anchor | ratio |")
    print("|---|---|---|---|---|---|")
    for b in builds:
        lr = summarize(res[b]["lockstep_rec"])
        ln = summarize(res[b]["lockstep_norec"])
        rt = summarize(res[b]["realtime"])
        done = sum(1 for r in res[b]["realtime"] if r["completed"])

        def row(what, fig, value, anchor, anchor_value, spec=".3f"):
            ratio = value / anchor_value if value is not None and anchor_value else None
            print(f"| {what} | {b} | {fig} | {fmt(value, spec)} | {anchor} "
                  f"{fmt(anchor_value, spec)} | {fmt(ratio, '.2f')} |")
        row("lockstep + recorder", "wall ms per tick (mean)", lr["tick_ms_mean"],
            "fan-out + recorder mean", fr and fr["tick_ms_mean"])
        row("lockstep + recorder", "wall ms per tick (median)", lr["tick_ms_median"],
            "fan-out + recorder median", fr and fr["tick_ms_median"])
        row("lockstep + recorder", "wall ms per tick (p99)", lr["tick_ms_p99"],
            "fan-out + recorder p99", fr and fr["tick_ms_p99"])
        row("lockstep + recorder", "simulated s per wall s", lr["speed"], "real time", 1.0)
        row("lockstep + recorder", "CPU s per simulated s (all processes)",
            lr["cpu_s_per_sim_s"], "fan-out + recorder", fr and fr["cpu_s_per_sim_s"])
        row("lockstep, no recorder", "simulated s per wall s", ln["speed"], "real time", 1.0)
        row("lockstep, no recorder", "CPU s per simulated s", ln["cpu_s_per_sim_s"],
            "fan-out, no recorder", fn and fn["cpu_s_per_sim_s"])
        print(f"| real time + recorder | {b} | sessions completed | {done} of "
              f"{len(res[b]['realtime'])} | | |")
        row("real time + recorder", "CPU s per simulated s (all processes)",
            rt["cpu_s_per_sim_s"], "fan-out + recorder", fr and fr["cpu_s_per_sim_s"])
        row("real time + recorder", "late ticks % (all legs)", rt["late_ticks_pct"],
            "cyclictest % > 0.5 ms", ct and ct["late_over_0_5ms_pct"])
        row("real time + recorder", "round trip median us", rt["round_trip_median_us"],
            "fan-out + recorder tick median us", fr and fr["tick_ms_median"] * 1e3, ".0f")
        row("real time + recorder", "round trip p99 us", rt["round_trip_p99_us"],
            "fan-out + recorder tick p99 us", fr and fr["tick_ms_p99"] * 1e3, ".0f")
        ratios = rmse_ratio(res[b]["realtime"], res[b]["lockstep_rec"])
        print(f"| real time + recorder | {b} | RMSE real time / lockstep | " +
              ", ".join(f"{ax} {fmt(v, '.2f')}" for ax, v in ratios.items()) + " | | |")
    print()
    for b in builds:
        print(f"real-time runs ({b}): " + "; ".join(
            f"{'ok' if r['completed'] else 'FAILED exit ' + str(r['exit_code'])}"
            f" late {fmt(r.get('late_ticks_pct'))} %"
            + (f", {r['schedule_slips']} slips ({fmt(r.get('slipped_ms'), '.1f')} ms)"
               if r.get("schedule_slips") is not None else "")
            for r in res[b]["realtime"]))
        for kind, label in [("lockstep_rec", "lockstep + recorder"),
                            ("realtime", "real time + recorder")]:
            runs = [r for r in res[b][kind] if r.get("processes") and r.get("sim_time_s")]
            if runs:
                names = list(runs[0]["processes"])
                print(f"CPU s per simulated s per process, {label} ({b}, whole life incl. "
                      f"start-up, median): " + ", ".join(
                          f"{n} {med([r['processes'].get(n, 0) / r['sim_time_s'] for r in runs]):.3f}"
                          for n in names))


if __name__ == "__main__":
    main()
