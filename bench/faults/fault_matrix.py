#!/usr/bin/python3
"""Fault matrix of the HexaTaar system (docs/faults.md): every fault kind x leg x mode x
(standby or not), each as a whole hexa_session with the recorder on; one table with the exit
code, the detected cause, the detection latency, the platform's excursion in the second after
detection (ground truth), the standby take-over and the data lost in the recording.

    /usr/bin/python3 bench/faults/fault_matrix.py                # leg 3, both modes, +/- standby
    /usr/bin/python3 bench/faults/fault_matrix.py --legs all     # every leg
    /usr/bin/python3 bench/faults/fault_matrix.py --rt-series 20 [--stress 1]

--rt-series N runs N fault-free real-time sessions in a row instead (combined trajectory,
recorder on) and counts completions and recording gaps; --stress K runs `stress-ng --cpu K`
beside them. As root every session runs in its own network namespace (unshare -n), so that
nothing crosses to other users of the machine's DDS domains; otherwise on loopback with a
domain id of its own. Everything measured comes from the session's recording and logs:

  detected      the first FaultEvent after the injection: "source reason leg"
  latency       wall clock from the injection to that FaultEvent (its source timestamp), and in
                ticks; the injection instant is the publish time of the plant's sample of the
                first tick at or after the fault time (the sample the faulty process acts on)
  excursion     largest distance (mm) / rotation (deg) of the true platform pose in the 1 s
                (simulated) after detection from its pose at detection
  take-over     standby rows: publish time of the standby's first command - the primary's
                last command, as recorded (the recorder, like the plant, sees the owner's)
  lost          samples missing from the plant's streams (LegSensors x6, GroundTruth,
                ImuSample unless the IMU was the fault) by tick numbers (hexa_recorder info):
                the recorder lost them; and gaps of the leg controllers' ValveCommands
  after         standby rows: the largest gap between two recorded commands of the leg after
                the take-over (a standby that took over and then stalled shows here)
  CPU stalls    with --stall-probe: hexa_cpu_stall_probe runs beside each session (one
                SCHED_FIFO 99 thread per CPU, 1 ms period): per CPU the largest wake-up delay
                and the stalls over 5 ms, with the steal time the hypervisor reported; for a
                row whose session did not end as expected, the largest stall in the 40 ms
                before its first unexpected FaultEvent
"""
import argparse
import csv
import datetime
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import time

LEG_FAULTS = ["crash", "hang", "slow", "garbage", "silence"]
PLANT_LEG_FAULTS = ["pot-stuck", "pot-drift", "pressure-dead"]
PLANT_FAULTS = ["imu-dropout", "supply-loss"]
ALL_KINDS = LEG_FAULTS + PLANT_LEG_FAULTS + PLANT_FAULTS + ["supervisor-crash"]


def load():
    return " ".join(open("/proc/loadavg").read().split()[:3])


def session_command(args, build, out_dir, fault_args, mode, standby, domain):
    cmd = [os.path.join(build, "deploy/hexa_session"), "--trajectory", args.trajectory,
           "--periods", str(args.periods), "--mode", mode, "--seed", str(args.seed),
           "--out", out_dir, "--domain", str(domain), "--timeout", str(args.timeout)]
    if standby:
        cmd.append("--standby")
    cmd += args.session_arg
    cmd += fault_args
    return cmd


def start_probe(args, out_dir):
    """Starts the CPU stall probe (--stall-probe) for one session; returns (process, json path)."""
    if not args.stall_probe:
        return None, None
    os.makedirs(out_dir, exist_ok=True)
    path = os.path.join(out_dir, "cpu_stall_probe.json")
    proc = subprocess.Popen([os.path.join(args.build, "bench/faults/hexa_cpu_stall_probe"), "--out", path,
                             "--threshold-us", str(args.stall_threshold_us)],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, start_new_session=True)
    time.sleep(0.2)
    if proc.poll() is not None:
        sys.exit("fault_matrix: the CPU stall probe did not start: %s" % proc.stderr.read().decode().strip())
    return proc, path


def stop_probe(proc, path):
    """Stops the probe; returns its JSON (per_cpu, events) or None."""
    if proc is None:
        return None
    proc.send_signal(signal.SIGTERM)
    try:
        proc.wait(timeout=10)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
        return None
    try:
        with open(path) as f:
            return json.load(f)
    except (OSError, ValueError):
        return None


def stall_summary(probe):
    """'cpu0 12.1 ms (3 > 5 ms), cpu1 2.3 ms': each CPU's largest stall and its stalls over 5 ms."""
    if not probe:
        return "-"
    return ", ".join("cpu%d %.1f ms%s" % (c["cpu"], c["max_late_us"] / 1e3,
                                           " (%d > 5 ms)" % c["over_5ms"] if c["over_5ms"] else "")
                     for c in probe["per_cpu"])


def stall_before(probe, t_ns, window_ns=40000000):
    """The largest stall (cpu, ms, steal jiffies) that overlaps the window_ns before t_ns."""
    best = None
    for e in (probe or {}).get("events", []):
        start, end = e["due_realtime_ns"], e["due_realtime_ns"] + e["late_us"] * 1000
        if end >= t_ns - window_ns and start <= t_ns:
            if best is None or e["late_us"] > best["late_us"]:
                best = e
    if best is None:
        return None
    return "cpu%d %.1f ms (steal %d jiffies)" % (best["cpu"], best["late_us"] / 1e3, best["steal_jiffies"])


def run_session(args, cmd):
    """Runs one session (in its own network namespace when root); returns its exit code."""
    if args.netns:
        inner = "ip link set lo up && exec " + " ".join(_quote(c) for c in cmd)
        cmd = ["unshare", "-n", "sh", "-c", inner]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            start_new_session=True)
    try:
        return proc.wait(timeout=args.timeout + 120)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
        return -9


def _quote(s):
    return "'" + s.replace("'", "'\\''") + "'" if re.search(r"[^\w./:=,+-]", s) else s


def read_csv(path):
    if not os.path.exists(path):
        return []
    with open(path, newline="") as f:
        # Header cells are "name [unit]" (hexa_recorder export): keyed by name.
        return [{re.sub(r" \[[^\]]*\]$", "", k): v for k, v in row.items()}
                for row in csv.DictReader(f)]


def pose_of(truth_row):
    """(position, orientation wxyz) of a GroundTruth row: columns "position_m.x" ... as
    hexa_recorder exports them, or "position_m[0]" ..."""
    def get(field, k, axis):
        return float(col(truth_row, "%s.%s" % (field, axis), "%s[%d]" % (field, k)))
    return ([get("position_m", k, a) for k, a in enumerate("xyz")],
            [get("orientation_wxyz", k, a) for k, a in enumerate("wxyz")])


def export(build, mcap, out_dir):
    os.makedirs(out_dir, exist_ok=True)
    subprocess.run([os.path.join(build, "services/recorder/hexa_recorder"), "export", mcap,
                    "--out-dir", out_dir], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


def info_loss(build, mcap):
    """Per (topic, key): (missing, gaps, expected) from `hexa_recorder info`."""
    r = subprocess.run([os.path.join(build, "services/recorder/hexa_recorder"), "info", mcap],
                       capture_output=True, text=True)
    return parse_info_loss(r.stdout), r.returncode


def parse_info_loss(text):
    """Per (topic, key) from the "loss from tick numbers" lines of `hexa_recorder info`; the key
    is "-" or "leg N" (a per-leg instance: LegSensors, ValveCommand, LegSetpoint)."""
    loss = {}
    pat = re.compile(r"^\s+(hexa_\w+)\s+(-|leg \d+)\s+ticks (\d+)\.\.(\d+) step (\d+): (\d+) received, "
                     r"(\d+) expected, (\d+) missing in (\d+) gaps")
    for line in text.splitlines():
        m = pat.match(line)
        if m:
            loss[(m.group(1), m.group(2))] = {"missing": int(m.group(8)), "gaps": int(m.group(9)),
                                              "expected": int(m.group(7)),
                                              "first": int(m.group(3)), "last": int(m.group(4))}
    return loss


def col(row, *names):
    for n in names:
        if n in row and row[n] != "":
            return row[n]
    return None


def takeover(valves, leg):
    """(take-over ms, largest gap after it ms) of a leg from its recorded ValveCommand rows.

    The take-over is the standby's first command after the primary's last one. A standby
    sample before that (tick 0, or a primary late past its 1 ms deadline: Cyclone then lets the
    instance's next sample in from any live writer) is not the take-over. The gap after it
    shows a standby that took over and then stopped answering for a while."""
    is_standby = lambda v: col(v, "standby") in ("1", "true", "True")
    mine = [v for v in valves if int(col(v, "leg_id")) == leg]
    primary = [int(v["publish_time_ns"]) for v in mine if not is_standby(v)]
    if not primary:
        return None, None
    last_primary = max(primary)
    after = sorted(int(v["publish_time_ns"]) for v in mine
                   if is_standby(v) and int(v["publish_time_ns"]) > last_primary)
    if not after:
        return None, None
    gap = max(b - a for a, b in zip(after, after[1:])) * 1e-6 if len(after) > 1 else None
    return (after[0] - last_primary) * 1e-6, gap


def analyse(build, out_dir, case, fault_at_s):
    mcap = os.path.join(out_dir, "session.mcap")
    res = {"detected": "-", "lat_ms": None, "lat_ticks": None, "exc_mm": None, "exc_deg": None,
           "takeover_ms": None, "after_ms": None, "lost_plant": None, "cmd_gaps": None,
           "faults": 0, "first_fault_ns": None}
    if not os.path.exists(mcap):
        res["detected"] = "no recording"
        return res
    csv_dir = os.path.join(out_dir, "csv")
    export(build, mcap, csv_dir)
    sensors = read_csv(os.path.join(csv_dir, "hexa_LegSensors.csv"))
    faults = read_csv(os.path.join(csv_dir, "hexa_FaultEvent.csv"))
    truth = read_csv(os.path.join(csv_dir, "hexa_GroundTruth.csv"))
    valves = read_csv(os.path.join(csv_dir, "hexa_ValveCommand.csv"))
    fault_tick = int(round(fault_at_s * 1000))
    leg = case["leg"] if case["leg"] else 1
    # Injection instant: the plant's sample of the fault tick (of the faulty leg).
    inject_ns = None
    for s in sensors:
        if int(col(s, "header.tick", "tick")) == fault_tick and (
                int(col(s, "leg_id")) == leg):
            inject_ns = int(s["publish_time_ns"])
            break
    res["faults"] = len(faults)
    first = None
    for f in faults:
        if int(col(f, "tick")) + 5 >= fault_tick:  # events of this fault (not start-up)
            first = f
            break
    if first is not None:
        reason = col(first, "reason").replace("FAULT_", "")
        res["detected"] = "%s %s leg %s" % (col(first, "source_node"), reason, col(first, "leg_id"))
        det_tick = int(col(first, "tick"))
        res["lat_ticks"] = det_tick - fault_tick
        det_ns = int(col(first, "source_time_ns") or first["publish_time_ns"])
        res["first_fault_ns"] = det_ns
        if inject_ns is not None:
            res["lat_ms"] = (det_ns - inject_ns) * 1e-6
        # Excursion of the true pose in the simulated second after detection.
        by_tick = {}
        for t in truth:
            by_tick[int(col(t, "header.tick", "tick"))] = t
        if det_tick in by_tick:
            p0, q0 = pose_of(by_tick[det_tick])
            exc, rot = 0.0, 0.0
            for n in range(det_tick, det_tick + 1001):
                t = by_tick.get(n)
                if t is None:
                    continue
                p, q = pose_of(t)
                exc = max(exc, sum((a - b) ** 2 for a, b in zip(p, p0)) ** 0.5)
                dot = abs(sum(a * b for a, b in zip(q, q0)))
                rot = max(rot, 2.0 * __import__("math").acos(min(1.0, dot)))
            res["exc_mm"] = exc * 1e3
            res["exc_deg"] = rot * 57.29577951308232
    if case["standby"] and case["kind"] in LEG_FAULTS:
        res["takeover_ms"], res["after_ms"] = takeover(valves, leg)
    loss, _ = info_loss(build, mcap)
    lost = 0
    gaps = 0
    for (topic, key), l in loss.items():
        if topic in ("hexa_LegSensors", "hexa_GroundTruth") or (
                topic == "hexa_ImuSample" and case["kind"] != "imu-dropout"):
            lost += l["missing"]
        if topic == "hexa_ValveCommand":
            gaps += l["gaps"]
    res["lost_plant"] = lost
    res["cmd_gaps"] = gaps
    return res


def cases(args):
    legs = list(range(1, 7)) if args.legs == "all" else [int(x) for x in args.legs.split(",")]
    kinds = ALL_KINDS if args.kinds == "all" else args.kinds.split(",")
    modes = args.modes.split(",")
    standbys = {"both": [False, True], "no": [False], "yes": [True]}[args.standby]
    out = []
    for mode in modes:
        for kind in kinds:
            leg_kinds = LEG_FAULTS + PLANT_LEG_FAULTS
            for leg in (legs if kind in leg_kinds else [0]):
                for sb in (standbys if kind in LEG_FAULTS else [False]):
                    reps = args.repeat_rt if mode == "realtime" else 1
                    for rep in range(reps):
                        out.append({"mode": mode, "kind": kind, "leg": leg, "standby": sb,
                                    "rep": rep})
    return out


def fault_args(case, at):
    k, leg = case["kind"], case["leg"]
    if k in LEG_FAULTS:
        return ["--fault", "%d:%s:%g" % (leg, k, at)]
    if k == "supervisor-crash":
        return ["--fault", "supervisor:crash:%g" % at]
    return ["--plant-fault", "%s:%d:%g" % (k, leg, at)]


def fmt(v, f="%.1f"):
    return "-" if v is None else (f % v)


def run_matrix(args):
    rows = []
    all_cases = cases(args)
    print("fault matrix: %d sessions, load average %s, %s" % (len(all_cases), load(),
                                                              datetime.datetime.now().isoformat()))
    for n, case in enumerate(all_cases):
        name = "%s_%s_leg%d%s_%d" % (case["mode"], case["kind"], case["leg"],
                                     "_sb" if case["standby"] else "", case["rep"])
        out_dir = os.path.join(args.out, name)
        shutil.rmtree(out_dir, ignore_errors=True)
        domain = 100 + (os.getpid() + n) % 100
        cmd = session_command(args, args.build, out_dir, fault_args(case, args.fault_at),
                              case["mode"], case["standby"], domain)
        before = load()
        probe_proc, probe_path = start_probe(args, out_dir)
        t0 = time.time()
        rc = run_session(args, cmd)
        wall = time.time() - t0
        probe = stop_probe(probe_proc, probe_path)
        res = analyse(args.build, out_dir, case, args.fault_at)
        row = dict(case, exit=rc, wall_s=wall, load=before, **res)
        row["cpu_stalls"] = stall_summary(probe)
        row["stall_at_fault"] = None
        # A fault is unexpected in a take-over row (it should complete without one) and in any
        # session that did not end as a held fault should (exit 3, or 5 for the supervisor).
        taken_over = case["standby"] and case["kind"] in ("crash", "hang", "silence")
        if probe and res["first_fault_ns"] is not None and (taken_over or rc not in (3, 5)):
            row["stall_at_fault"] = stall_before(probe, res["first_fault_ns"])
        rows.append(row)
        print("%3d/%d %-9s %-16s leg %d %-3s exit %3s  %-44s %8s ms %6s ticks  exc %6s mm %5s deg  "
              "take-over %6s ms (after: %s ms)  lost %s  cmd gaps %s  (%.0f s, load %s)%s%s" % (
                  n + 1, len(all_cases), case["mode"], case["kind"], case["leg"],
                  "sb" if case["standby"] else "", rc, row["detected"], fmt(row["lat_ms"]),
                  fmt(row["lat_ticks"], "%d"), fmt(row["exc_mm"]), fmt(row["exc_deg"], "%.2f"),
                  fmt(row["takeover_ms"]), fmt(row["after_ms"]), fmt(row["lost_plant"], "%d"),
                  fmt(row["cmd_gaps"], "%d"), wall, before,
                  "  stalls: " + row["cpu_stalls"] if args.stall_probe else "",
                  "  stall before the fault: " + row["stall_at_fault"] if row["stall_at_fault"] else ""),
              flush=True)
    with open(os.path.join(args.out, "fault_matrix.json"), "w") as f:
        json.dump(rows, f, indent=1)
    with open(os.path.join(args.out, "fault_matrix.md"), "w") as f:
        f.write("| mode | fault | leg | standby | exit | detected (source reason leg) | latency ms | "
                "latency ticks | excursion mm / deg (1 s after) | take-over ms | largest command "
                "gap after take-over ms | lost (plant streams) | command gaps | CPU stalls | stall "
                "before the first unexpected fault |\n"
                "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n")
        for r in rows:
            f.write("| %s | %s | %s | %s | %s | %s | %s | %s | %s / %s | %s | %s | %s | %s | %s | %s |\n" % (
                r["mode"], r["kind"], r["leg"] or "-", "yes" if r["standby"] else "no", r["exit"],
                r["detected"], fmt(r["lat_ms"]), fmt(r["lat_ticks"], "%d"), fmt(r["exc_mm"]),
                fmt(r["exc_deg"], "%.2f"), fmt(r["takeover_ms"]), fmt(r["after_ms"]),
                fmt(r["lost_plant"], "%d"), fmt(r["cmd_gaps"], "%d"), r["cpu_stalls"],
                r["stall_at_fault"] or "-"))
    print("table: %s  (load average at the end %s)" % (os.path.join(args.out, "fault_matrix.md"),
                                                       load()))


def run_series(args):
    stress = None
    if args.stress > 0:
        stress = subprocess.Popen(["stress-ng", "--cpu", str(args.stress), "--quiet"],
                                  stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                  start_new_session=True)
        time.sleep(1)
    rows = []
    print("real-time series: %d sessions (combined, %d periods, recorder on)%s, load average %s" % (
        args.rt_series, args.periods, ", stress-ng --cpu %d beside" % args.stress if stress else "",
        load()))
    try:
        for n in range(args.rt_series):
            out_dir = os.path.join(args.out, "rt_%s%02d" % ("stress_" if stress else "", n))
            shutil.rmtree(out_dir, ignore_errors=True)
            domain = 100 + (os.getpid() + n) % 100
            cmd = session_command(args, args.build, out_dir, [], "realtime", False, domain)
            before = load()
            probe_proc, probe_path = start_probe(args, out_dir)
            rc = run_session(args, cmd)
            probe = stop_probe(probe_proc, probe_path)
            mcap = os.path.join(out_dir, "session.mcap")
            loss, _ = info_loss(args.build, mcap) if os.path.exists(mcap) else ({}, 1)
            gaps = {}
            for (topic, key), l in loss.items():
                g = gaps.setdefault(topic, [0, 0])
                g[0] += l["gaps"]
                g[1] += l["missing"]
            why = ""
            log = os.path.join(out_dir, "session.log")
            if rc != 0 and os.path.exists(log):
                plant = os.path.join(out_dir, "plant.log")
                lines = [l.strip() for l in open(plant)] if os.path.exists(plant) else []
                hits = [l for l in lines if "FAULT" in l or "host overload" in l or (
                    "leg " in l and ("liveliness" in l or "stale" in l or "writer" in l))]
                why = hits[0][-160:] if hits else ""
            rec_summary = ""
            rlog = os.path.join(out_dir, "recorder.console.log")
            if os.path.exists(rlog):
                rec_summary = " ".join(l.strip() for l in open(rlog) if l.startswith("hexa_"))
            row = {"run": n, "exit": rc, "load": before, "gaps": gaps, "why": why,
                   "recorder": rec_summary, "cpu_stalls": stall_summary(probe)}
            rows.append(row)
            gap_text = " ".join("%s %d/%d" % (t.replace("hexa_", ""), g[0], g[1])
                                for t, g in sorted(gaps.items()))
            print("%2d exit %d  gaps/missing: %s  (load %s)%s %s" % (
                n + 1, rc, gap_text, before,
                "  stalls: " + row["cpu_stalls"] if args.stall_probe else "", why), flush=True)
    finally:
        if stress:
            os.killpg(stress.pid, signal.SIGTERM)
            stress.wait()
    completed = sum(1 for r in rows if r["exit"] == 0)
    zero_gap = sum(1 for r in rows if r["gaps"] and all(
        g[0] == 0 for t, g in r["gaps"].items() if t in ("hexa_LegSensors", "hexa_GroundTruth",
                                                          "hexa_ImuSample")))
    print("completed %d of %d; recordings without a gap in the plant's streams: %d of %d; load "
          "average at the end %s" % (completed, len(rows), zero_gap, len(rows), load()))
    with open(os.path.join(args.out, "rt_series%s.json" % ("_stress" if stress else "")), "w") as f:
        json.dump(rows, f, indent=1)


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--build", default="build")
    p.add_argument("--out", default="out/faults-" + datetime.datetime.now().strftime("%Y%m%d-%H%M%S"))
    p.add_argument("--modes", default="lockstep,realtime")
    p.add_argument("--legs", default="3", help="comma list of legs, or 'all'")
    p.add_argument("--kinds", default="all", help="comma list of " + " ".join(ALL_KINDS))
    p.add_argument("--standby", default="both", choices=["both", "no", "yes"])
    p.add_argument("--repeat-rt", type=int, default=2, help="runs of every real-time row")
    p.add_argument("--fault-at", type=float, default=1.5, help="simulated time of the fault (s)")
    p.add_argument("--trajectory", default="combined")
    p.add_argument("--periods", type=int, default=1)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--timeout", type=float, default=180)
    p.add_argument("--rt-series", type=int, default=0)
    p.add_argument("--stress", type=int, default=0, help="stress-ng --cpu N beside the series")
    p.add_argument("--netns", choices=["auto", "yes", "no"], default="auto")
    p.add_argument("--stall-probe", action="store_true",
                   help="run hexa_cpu_stall_probe beside every session (root): CPU stalls per "
                        "session and the stall before an unexpected fault")
    p.add_argument("--stall-threshold-us", type=int, default=2000,
                   help="with --stall-probe: a wake-up later than this is a stall (default 2000)")
    p.add_argument("--session-arg", action="append", default=[],
                   help="extra hexa_session argument for every session (repeatable; use "
                        "--session-arg=--rt-lease --session-arg=0.02)")
    args = p.parse_args()
    args.netns = (os.geteuid() == 0) if args.netns == "auto" else args.netns == "yes"
    args.build = os.path.abspath(args.build)
    os.makedirs(args.out, exist_ok=True)
    args.out = os.path.abspath(args.out)
    if args.rt_series > 0:
        if args.periods == 1 and "--periods" not in sys.argv:
            args.periods = 2
        run_series(args)
    else:
        run_matrix(args)


if __name__ == "__main__":
    main()
