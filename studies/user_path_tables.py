#!/usr/bin/python3
"""Tables 9 and 10 through the path a user takes, over DDS: for each seed, the calibration
session (`hexa_session --trajectory calibration --tracker`), the fit (`hexa_calibrate
session.mcap --out calibration.textproto`), then the seven paper trajectories with
`hexa_session --rig-overlay calibration.textproto` (lockstep, BS-SMC, realistic profile by
default). Reads every session's report.json and prints a markdown section: RMSE against ground
truth per axis (cm / deg, median over the seeds), the paper's figures, one fifth of them and
the ratio, plus the valve activity on combined. With --in-process it also runs `hexa_sim` with
the same overlay and seed (the in-process lockstep simulation) and lists the largest difference
per seed: the two paths must agree.

The seed is the plant's (`hexa_session --seed` = `hexa_sim --seed`): noise, calibration errors
and the tracker's noise all derive from it.

With --coupled-legs the seven trajectories (and hexa_sim) run with the coupled leg feedback
(`hexa_session --coupled-legs`, docs/controller.md "Coupled leg feedback"); the calibration
session stays decoupled, as a user calibrates (docs/calibration.md).

--trajectories runs a subset of the seven (e.g. z,combined); the cells of the others read n/a.

Usage: /usr/bin/python3 studies/user_path_tables.py [--build build] [--seeds 1,2,3]
       [--out out/user_path] [--in-process] [--reuse] [--coupled-legs]
       [--trajectories x,y,z,roll,pitch,yaw,combined] [--doc docs/measurements/results.md]
"""
import argparse
import datetime
import json
import os
import statistics
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from accuracy_tables import PAPER9, PAPER10  # noqa: E402  (cm, deg: Tables 9 and 10)

SECTION = "## Through the user's path over DDS"
NEXT_SECTION = "## DDS sessions"  # studies/paper_tables.py rewrites the page from there on
TRAJ = ["x", "y", "z", "roll", "pitch", "yaw", "combined"]
AXES = ["x", "y", "z", "roll", "pitch", "yaw"]
DEG = 57.29577951308232


def progress(msg):
    sys.stderr.write(f"[{time.strftime('%H:%M:%S')}] {msg}\n")
    sys.stderr.flush()


def report_axes(report):
    """RMSE against ground truth in cm (x y z) and deg (roll pitch yaw), or None when the
    session never tracked (no report, or HOLD before the tracking window)."""
    if report is None or not report.get("tracking_pose_samples"):
        return None
    r = report["rmse_vs_ground_truth"]
    out = []
    for k, a in enumerate(AXES):
        v = r.get(a + ("_m" if k < 3 else "_rad"))
        out.append(None if v is None else v * (100.0 if k < 3 else DEG))
    return out


def valve_activity(report):
    """(mean |dV| per tick in V, % of ticks saturated, worst valve's %) over the six valves of a
    report (report.json gives both per valve), or None."""
    steps = report.get("valve_mean_abs_step_v_per_tick") if report else None
    if not steps or None in steps:  # null: no GroundTruth recorded, activity unknown
        return None
    sat = report["valve_saturated_fraction"]
    return (statistics.mean(report["valve_mean_abs_step_v_per_tick"]),
            100.0 * statistics.mean(sat), 100.0 * max(sat))


def run(cmd, log_path, reuse_path=None):
    """Runs cmd (output to log_path) unless --reuse finds reuse_path; returns (exit, wall s)."""
    if reuse_path and os.path.exists(reuse_path):
        return 0, 0.0
    t0 = time.time()
    with open(log_path, "w") as log:
        p = subprocess.run(cmd, stdout=log, stderr=subprocess.STDOUT)
    return p.returncode, time.time() - t0


def load_json(path):
    if not os.path.exists(path):
        return None
    with open(path) as f:
        return json.load(f)


def run_seed(a, seed, domain):
    """The user's path for one seed: {"calibration": exit, "sessions": {traj: report},
    "in_process": {traj: axes} or None, "commands": [...]}."""
    root = os.path.join(a.out, f"seed{seed}")
    os.makedirs(root, exist_ok=True)
    session = os.path.join(a.build, "deploy", "hexa_session")
    common = ["--controller", a.controller, "--profile", a.profile, "--seed", str(seed),
              "--mode", "lockstep", "--domain", str(domain), "--timeout", str(a.timeout)]
    rig = ["--rig", a.rig] if a.rig else []
    common += rig + (["--lockstep-lease", str(a.lockstep_lease)] if a.lockstep_lease else [])
    res = {"sessions": {}, "in_process": None, "commands": []}
    cal_dir = os.path.join(root, "calibration")
    overlay = os.path.join(cal_dir, "calibration.textproto")
    cmd = [session, "--trajectory", "calibration", "--tracker", "--out", cal_dir] + common
    res["commands"].append(cmd)
    progress(f"seed {seed}: calibration session -> {cal_dir}")
    code, wall = run(cmd, os.path.join(root, "calibration.log"),
                     os.path.join(cal_dir, "session.mcap") if a.reuse else None)
    progress(f"seed {seed}: calibration session exit {code} ({wall:.0f} s)")
    cmd = [os.path.join(a.build, "tools", "hexa_calibrate"), os.path.join(cal_dir, "session.mcap"),
           "--out", overlay, "--truth-seed", str(seed), "--truth-profile", a.profile] + rig
    res["commands"].append(cmd)
    code, wall = run(cmd, os.path.join(root, "hexa_calibrate.log"), overlay if a.reuse else None)
    res["calibration_exit"] = code
    progress(f"seed {seed}: hexa_calibrate exit {code} ({wall:.0f} s) -> {overlay}")
    if code != 0 or not os.path.exists(overlay):
        progress(f"seed {seed}: no calibration overlay; see {root}/hexa_calibrate.log")
        return res
    coupled = ["--coupled-legs"] if a.coupled_legs else []
    trajs = getattr(a, "trajectories", TRAJ)
    for t in trajs:
        d = os.path.join(root, t)
        cmd = [session, "--trajectory", t, "--rig-overlay", overlay, "--out", d] + common + coupled
        res["commands"].append(cmd)
        code, wall = run(cmd, os.path.join(root, f"{t}.log"),
                         os.path.join(d, "report.json") if a.reuse else None)
        res["sessions"][t] = load_json(os.path.join(d, "report.json"))
        ax = report_axes(res["sessions"][t])
        progress(f"seed {seed}: {t:8s} exit {code} ({wall:.0f} s) RMSE "
                 + ("n/a" if ax is None else " ".join(f"{v:.4f}" for v in ax)))
    if a.in_process:
        # All seven in one run, or one hexa_sim run per trajectory of a subset.
        runs = [("all", "in_process")] if trajs == TRAJ else [(t, f"in_process_{t}") for t in trajs]
        res["in_process"] = {}
        for traj, name in runs:
            j = os.path.join(root, name + ".json")
            cmd = [os.path.join(a.build, "tools", "hexa_sim"), "--controller", a.controller,
                   "--profile", a.profile, "--seed", str(seed)] \
                + ([] if traj == "all" else ["--trajectory", traj]) \
                + ["--rig-overlay", overlay, "--json", j] + rig + coupled
            res["commands"].append(cmd)
            code, wall = run(cmd, os.path.join(root, name + ".log"), j if a.reuse else None)
            progress(f"seed {seed}: hexa_sim {traj} with the same overlay exit {code} ({wall:.0f} s)")
            sim = load_json(j)
            if sim:
                res["in_process"].update({
                    t: [v * (100.0 if k < 3 else DEG) for k, v in enumerate(r["rmse_vs_truth"])]
                    for t, r in sim["trajectories"].items() if r.get("completed")})
    return res


def cells():
    """The 12 cells of Tables 9 and 10: (trajectory, axis index, paper figure)."""
    return ([(t, k, PAPER9[k]) for k, t in enumerate(TRAJ[:6])]
            + [("combined", k, PAPER10[k]) for k in range(6)])


def median_cell(results, seeds, traj, k):
    vals = []
    for s in seeds:
        ax = report_axes(results[s]["sessions"].get(traj))
        if ax is None or ax[k] is None:
            return None  # a cell is only reported when every seed gave a figure
        vals.append(ax[k])
    return statistics.median(vals)


def f3(v):
    return "n/a" if v is None else f"{v:.3f}"


def format_section(results, seeds, command, date, commit, coupled=False, trajs=TRAJ):
    """The markdown section (Table 9/10 layout, the 12 cells against one fifth of the paper,
    valve activity on combined, agreement with the in-process simulation)."""
    seed_list = ", ".join(map(str, seeds))
    L = [f"{SECTION} (calibrated, median of seeds {seed_list}; {date}, on {commit})\n",
         f"Generated by `{command}`. For each seed, the path of docs/calibration.md over loopback "
         "DDS (every process started by `hexa_session`; lockstep, BS-SMC, `realistic` profile): "
         "`hexa_session --trajectory calibration --tracker --out DIR`, `hexa_calibrate "
         "DIR/session.mcap --out DIR/calibration.textproto`, then `hexa_session --trajectory T "
         "--rig-overlay DIR/calibration.textproto` for "
         + ("the seven trajectories" if trajs == TRAJ else "the trajectories " + ", ".join(trajs))
         + (" with `--coupled-legs` (the coupled leg feedback; the calibration session "
            "decoupled)" if coupled else "") + ". RMSE against "
         "ground truth over the tracking window, from each session's report.json; median over "
         "the seeds per cell. Table 9 cells: the moving axis of each pure motion; Table 10: the "
         "combined trajectory (eq 49).\n"]
    L.append("| | X cm | Y cm | Z cm | rot X deg | rot Y deg | rot Z deg |")
    L.append("|---|---|---|---|---|---|---|")
    t9 = [median_cell(results, seeds, TRAJ[k], k) for k in range(6)]
    t10 = [median_cell(results, seeds, "combined", k) for k in range(6)]
    law = "BS-SMC, coupled legs" if coupled else "BS-SMC"
    for name, row in [(f"Table 9 layout (pure motions): {law}, calibrated, DDS", t9),
                      ("paper, Table 9", PAPER9),
                      ("one fifth of Table 9", [p / 5 for p in PAPER9]),
                      (f"Table 10 layout (combined): {law}, calibrated, DDS", t10),
                      ("paper, Table 10", PAPER10),
                      ("one fifth of Table 10", [p / 5 for p in PAPER10])]:
        L.append(f"| {name} | " + " | ".join(f3(v) for v in row) + " |")
    L.append("")
    per_seed = len(seeds) > 1
    L.append("| trajectory | axis | RMSE | paper | paper / 5 | RMSE / (paper / 5) | <= paper / 5 |"
             + (" " + " | ".join(f"seed {s}" for s in seeds) + " |" if per_seed else ""))
    L.append("|---|---|---|---|---|---|---|" + ("---|" * len(seeds) if per_seed else ""))
    met = 0
    for t, k, p in cells():
        v = median_cell(results, seeds, t, k)
        ok = v is not None and v <= p / 5
        met += ok
        row = (f"| {t} | {AXES[k]} | {f3(v)} | {p:.3f} | {p / 5:.3f} | "
               f"{'n/a' if v is None else f'{v / (p / 5):.2f}'} | {'yes' if ok else 'NO'} |")
        if per_seed:
            for s in seeds:
                ax = report_axes(results[s]["sessions"].get(t))
                row += f" {f3(None if ax is None else ax[k])} |"
        L.append(row)
    L.append("")
    run_cells = sum(1 for t, _, _ in cells() if t in trajs)
    L.append(f"{met} of the 12 cells at most one fifth of the paper"
             + ("" if run_cells == 12 else f" ({run_cells} cells run; n/a: trajectory not run)") + ".\n")
    valves = [(s, valve_activity(results[s]["sessions"].get("combined"))) for s in seeds]
    L.append("Valve activity on combined (mean over the six valves of the mean |dV| per tick and "
             "of the share of ticks at 0.05 V or 9.95 V; in brackets the worst valve's share): "
             + "; ".join(f"seed {s}: " + ("n/a" if v is None else
                                          f"{v[0]:.3f} V per tick, {v[1]:.2f} % ({v[2]:.2f} %)")
                         for s, v in valves) + ".\n")
    agree = []
    for s in seeds:
        sim = results[s].get("in_process")
        if not sim:
            continue
        worst = 0.0
        for t in trajs:
            ax = report_axes(results[s]["sessions"].get(t))
            if ax is None or t not in sim:
                worst = float("inf")
                continue
            worst = max(worst, max(abs(x - y) for x, y in zip(ax, sim[t])))
        agree.append(f"seed {s}: largest difference over the {len(trajs)} x 6 figures {worst:.2e} (cm / deg)")
    if agree:
        L.append("Against the in-process simulation with the same overlay and seed (`hexa_sim "
                 "--seed N --rig-overlay DIR/calibration.textproto`): " + "; ".join(agree) + ".\n")
    return "\n".join(L)


def write_doc(doc, section):
    """Puts the section into doc: replaces an earlier one, else inserts it before the section
    that studies/paper_tables.py rewrites (or at the end)."""
    with open(doc) as f:
        text = f.read()
    body = section.rstrip("\n") + "\n\n"
    start = text.find(SECTION)
    if start >= 0:
        end = text.find("\n## ", start + len(SECTION))
        end = len(text) if end < 0 else end + 1
        text = text[:start] + body + text[end:]
    else:
        at = text.find(NEXT_SECTION)
        text = (text[:at] + body + text[at:]) if at >= 0 else text.rstrip("\n") + "\n\n" + body
    with open(doc, "w") as f:
        f.write(text)


def main():
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    here = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    ap.add_argument("--build", default=os.path.join(here, "build"))
    ap.add_argument("--seeds", default="1,2,3", help="plant seeds, comma separated")
    ap.add_argument("--out", default=os.path.join(here, "out", "user_path"),
                    help="sessions go to OUT/seedN/{calibration,x,...,combined}")
    ap.add_argument("--controller", choices=["bssmc", "pi"], default="bssmc")
    ap.add_argument("--profile", default="realistic")
    ap.add_argument("--rig", help="rig file for every tool (default: the tools' own default)")
    ap.add_argument("--lockstep-lease", type=float,
                    help="hexa_session --lockstep-lease in s (default: the session's, 0.2 s); on a "
                         "heavily loaded machine a host stall longer than the lease ends a session "
                         "in HOLD, a longer lease changes no figure")
    ap.add_argument("--timeout", type=int, default=0,
                    help="wall-clock limit of each hexa_session in s (0 = none)")
    ap.add_argument("--in-process", action="store_true",
                    help="also run hexa_sim with the same overlay and seed and compare")
    ap.add_argument("--reuse", action="store_true",
                    help="skip a step whose output (session.mcap, overlay, report.json) exists")
    ap.add_argument("--coupled-legs", action="store_true",
                    help="run the seven trajectories (and hexa_sim) with --coupled-legs; the "
                         "calibration session stays decoupled")
    ap.add_argument("--trajectories", default=",".join(TRAJ),
                    help="the trajectories to run, comma separated (default: all seven)")
    ap.add_argument("--doc", help="also put the section into this page (e.g. "
                                  "docs/measurements/results.md)")
    a = ap.parse_args()
    try:
        seeds = [int(s) for s in a.seeds.split(",")]
    except ValueError:
        ap.error(f"--seeds '{a.seeds}': expected integers separated by commas, e.g. 1,2,3")
    a.trajectories = [t.strip() for t in a.trajectories.split(",") if t.strip()]
    unknown = [t for t in a.trajectories if t not in TRAJ]
    if unknown or not a.trajectories:
        ap.error(f"--trajectories: unknown {', '.join(unknown) or '(none given)'}; choose from {', '.join(TRAJ)}")
    a.trajectories = [t for t in TRAJ if t in a.trajectories]  # the tables' order
    for exe in ["deploy/hexa_session", "tools/hexa_calibrate"] + (["tools/hexa_sim"] if a.in_process else []):
        if not os.access(os.path.join(a.build, exe), os.X_OK):
            ap.error(f"--build {a.build}: {exe} not found (build it: ./scripts/build.sh)")
    os.makedirs(a.out, exist_ok=True)
    domain = 150 + os.getpid() % 50
    results = {s: run_seed(a, s, domain) for s in seeds}
    commit = subprocess.run(["git", "-C", here, "rev-parse", "--short", "HEAD"],
                            capture_output=True, text=True).stdout.strip() or "unknown commit"
    command = "/usr/bin/python3 studies/user_path_tables.py " + " ".join(sys.argv[1:])
    section = format_section(results, seeds, command.strip(),
                             datetime.date.today().isoformat(), commit, a.coupled_legs, a.trajectories)
    with open(os.path.join(a.out, "section.md"), "w") as f:
        f.write(section + "\n")
    with open(os.path.join(a.out, "commands.txt"), "w") as f:
        for s in seeds:
            for c in results[s]["commands"]:
                f.write(" ".join(c) + "\n")
    if a.doc:
        write_doc(a.doc, section)
        progress(f"section written to {a.doc}")
    print(section)
    complete = all(report_axes(results[s]["sessions"].get(t)) for s in seeds for t in a.trajectories)
    return 0 if complete else 1


if __name__ == "__main__":
    sys.exit(main())
