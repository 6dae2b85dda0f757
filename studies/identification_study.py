#!/usr/bin/python3
"""Regenerates docs/measurements/identification_results.md (docs/identification.md explains the method):

  0. the kinematic calibration (hexa_session --trajectory calibration --tracker, hexa_calibrate),
     whose overlay hexa_identify uses for the joints and potentiometers;
  1. the identification experiment through the whole system (hexa_session --experiment
     identify: plant, six leg controllers, supervisor, recorder over loopback DDS; every leg
     driven open loop in turn), and the free-fall bench (hexa_session --experiment free-fall);
  2. hexa_identify on both recordings: the GA of Table 7 and least squares (Ceres), the
     Table 8 tables against the plant's truth, the rig overlay, plots;
  3. the friction-model study (identification_friction_study: static eq 3 vs LuGre, one leg);
  4. the closed loop in the in-process simulation (hexa_sim, the services' code path for the
     overlays): seven paper trajectories, realistic, BS-SMC, seeds 1-3, with the rig file's
     nominal values, the identified overlay, an overlay holding the plant's truth, and two
     diagnostic halves of the identified overlay.

Usage (DDS runs: run it inside a private network namespace if others use the machine):
  /usr/bin/python3 studies/identification_study.py [--build build] [--out out/identification]
      [--excite-duration 120] [--seed 1] [--max-iterations 1000] [--reuse] [--doc docs/measurements/identification_results.md]
"""
import argparse
import json
import os
import subprocess
import sys
import time

TRAJ = ["x", "y", "z", "roll", "pitch", "yaw", "combined"]
NAMES = ["v_s", "B", "F_s", "F_c", "gamma_o", "gamma_i", "gamma_k"]
TARGET = [10, 10, 5, 5, 5, 5, 5]
DEG = 57.29577951308232


def run(cmd, log=None, check=True):
    sys.stderr.write("$ " + " ".join(cmd) + "\n")
    t0 = time.time()
    with open(log, "w") if log else open(os.devnull, "w") as out:
        p = subprocess.run(cmd, stdout=out, stderr=subprocess.STDOUT)
    wall = time.time() - t0
    if check and p.returncode != 0:
        sys.exit(f"failed ({p.returncode}) after {wall:.0f} s: {' '.join(cmd)}" + (f"; log {log}" if log else ""))
    return wall


def load_average():
    with open("/proc/loadavg") as f:
        return " ".join(f.read().split()[:3])


def filter_overlay(src, dst, keep_gravity, keep_pneumatic):
    """A copy of an overlay with only its gravity loads, or only its pneumatic values."""
    out, depth, skipping = [], 0, 0
    for line in open(src):
        s = line.strip()
        if skipping:
            skipping += line.count("{") - line.count("}")
            continue
        if not keep_pneumatic and (s.startswith("friction {") or s.startswith("polytropic {")):
            skipping = line.count("{") - line.count("}")
            continue
        if not keep_gravity and s.startswith("gravity_load_n"):
            continue
        out.append(line)
    with open(dst, "w") as f:
        f.writelines(out)


# Closed-loop modes: (title, file tag, extra hexa_sim arguments).
MODES = [("BS-SMC with the platform feed-forward (default)", "", []),
         ("BS-SMC paper-faithful (--no-feedforward: the gravity load of eq 14 comes from the rig / overlay)",
          "noff_", ["--no-feedforward"])]


def sim(build, out_dir, name, seed, overlays, reuse, mode=("", "", [])):
    path = os.path.join(out_dir, f"closed_loop_{mode[1]}{name}_seed{seed}.json")
    if not (reuse and os.path.exists(path)):
        cmd = [os.path.join(build, "tools", "hexa_sim"), "--seed", str(seed), "--json", path] + mode[2]
        for o in overlays:
            cmd += ["--rig-overlay", o]
        run(cmd)
    with open(path) as f:
        return json.load(f)


def norm3(v):
    return (v[0] ** 2 + v[1] ** 2 + v[2] ** 2) ** 0.5


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--build", default="build")
    ap.add_argument("--out", default="out/identification")
    ap.add_argument("--excite-duration", type=float, default=120.0,
                    help="seconds of excitation per leg (default 120: the extend stroke's F_c has a 1-sigma noise error of 3-4 %% at 60 s, 2.4-2.7 %% at 120 s; docs/identification.md)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--max-iterations", type=int, default=1000)
    ap.add_argument("--domain", type=int, default=151)
    ap.add_argument("--reuse", action="store_true", help="reuse recordings and results found in --out")
    ap.add_argument("--doc", default="docs/measurements/identification_results.md")
    ap.add_argument("--diagnostics", action="store_true",
                    help="closed loop also with the identified overlay's pneumatic values only and its gravity loads only")
    ap.add_argument("--in-process", action="store_true",
                    help="record the experiments with hexa_sim (in-process lockstep) instead of a DDS session")
    ap.add_argument("--calibration", default=None,
                    help="kinematic calibration overlay to identify with (hexa_calibrate's output); default: "
                         "run the calibration session (DDS) and hexa_calibrate first")
    ap.add_argument("--no-calibration", action="store_true",
                    help="identify with the rig file's nominal joints and potentiometers (the state before "
                         "the kinematic calibration reached hexa_identify)")
    a = ap.parse_args()
    b, out = a.build, a.out
    os.makedirs(out, exist_ok=True)
    timings = {}

    # 0. Kinematic calibration (docs/calibration.md): the identification's inverse dynamics
    #    needs the rig's true joints and potentiometers as the calibrated controllers know them.
    #    Through DDS in both modes (hexa_sim --calibrate does not write an overlay).
    calibration = None
    if not a.no_calibration:
        calibration = a.calibration or os.path.join(out, "calibration.textproto")
        if a.calibration is None and not (a.reuse and os.path.exists(calibration)):
            cal_dir = os.path.join(out, "calibration-session")
            timings["calibration session"] = run([os.path.join(b, "deploy", "hexa_session"), "--trajectory",
                                                  "calibration", "--tracker", "--seed", str(a.seed),
                                                  "--profile", "realistic", "--out", cal_dir,
                                                  "--domain", str(a.domain + 2), "--timeout", "3600"],
                                                 os.path.join(out, "calibration-session.log"))
            timings["hexa_calibrate"] = run([os.path.join(b, "tools", "hexa_calibrate"),
                                             os.path.join(cal_dir, "session.mcap"), "--out", calibration,
                                             "--truth-seed", str(a.seed)],
                                            os.path.join(out, "hexa_calibrate.log"))

    # 1. Experiments: through the system (DDS session), or in process (hexa_sim).
    if a.in_process:
        ident_mcap = os.path.join(out, "identify-inprocess.mcap")
        ff_mcap = os.path.join(out, "free-fall-inprocess.mcap")
        if not (a.reuse and os.path.exists(ident_mcap)):
            timings["identify experiment (in process)"] = run(
                [os.path.join(b, "tools", "hexa_sim"), "--experiment", "identify", "--legs", "1-6",
                 "--excite-duration", str(a.excite_duration), "--seed", str(a.seed), "--profile", "realistic",
                 "--record", ident_mcap], os.path.join(out, "identify-inprocess.log"))
        if not (a.reuse and os.path.exists(ff_mcap)):
            timings["free-fall experiment (in process)"] = run(
                [os.path.join(b, "tools", "hexa_sim"), "--experiment", "free-fall", "--seed", str(a.seed),
                 "--profile", "realistic", "--record", ff_mcap], os.path.join(out, "free-fall-inprocess.log"))
    else:
        ident = os.path.join(out, "identify-session")
        ident_mcap = os.path.join(ident, "session.mcap")
        if not (a.reuse and os.path.exists(ident_mcap)):
            timings["identify session"] = run([os.path.join(b, "deploy", "hexa_session"), "--experiment", "identify",
                                               "--legs", "1-6", "--excite-duration", str(a.excite_duration),
                                               "--seed", str(a.seed), "--profile", "realistic", "--out", ident,
                                               "--domain", str(a.domain), "--timeout", "3600"],
                                              os.path.join(out, "identify-session.log"))
        ff = os.path.join(out, "free-fall-session")
        ff_mcap = os.path.join(ff, "session.mcap")
        if not (a.reuse and os.path.exists(ff_mcap)):
            timings["free-fall session"] = run([os.path.join(b, "deploy", "hexa_session"), "--experiment", "free-fall",
                                                "--seed", str(a.seed), "--profile", "realistic", "--out", ff,
                                                "--domain", str(a.domain + 1), "--timeout", "600"],
                                               os.path.join(out, "free-fall-session.log"))

    # 2. Identification.
    idd = os.path.join(out, "identified")
    truth_overlay = os.path.join(out, "truth_overlay.textproto")
    if not (a.reuse and os.path.exists(os.path.join(idd, "identification.json"))):
        timings["hexa_identify"] = run([os.path.join(b, "tools", "hexa_identify"),
                                        ident_mcap, "--out", idd, "--free-fall", ff_mcap,
                                        "--truth-overlay", truth_overlay,
                                        "--max-iterations", str(a.max_iterations)]
                                       + (["--rig-overlay", calibration] if calibration else []),
                                       os.path.join(out, "hexa_identify.log"), check=False)
    with open(os.path.join(idd, "identification.json")) as f:
        result = json.load(f)
    overlay = result["overlay"]
    if overlay is None:
        sys.exit("hexa_identify refused the overlay (see identification.md)")

    # 3. Friction-model study.
    friction_study = os.path.join(out, "friction_model_study.md")
    if not (a.reuse and os.path.exists(friction_study)):
        with open(friction_study, "w") as f:
            subprocess.run([os.path.join(b, "studies", "identification_friction_study")],
                           stdout=f, check=True)

    # 4. Closed loop.
    pneumatic_only = os.path.join(out, "identified_pneumatics_only.textproto")
    gravity_only = os.path.join(out, "identified_gravity_only.textproto")
    filter_overlay(overlay, pneumatic_only, keep_gravity=False, keep_pneumatic=True)
    filter_overlay(overlay, gravity_only, keep_gravity=True, keep_pneumatic=False)
    rigs = [("nominal", []), ("identified", [overlay]), ("truth", [truth_overlay])]
    if a.diagnostics:
        rigs += [("identified pneumatics only", [pneumatic_only]), ("identified gravity loads only", [gravity_only])]
    t0 = time.time()
    closed = {}
    for mode in MODES:
        for name, ovs in rigs:
            for seed in (1, 2, 3):
                closed[(mode[0], name, seed)] = sim(b, out, name.replace(" ", "_"), seed, ovs, a.reuse, mode)
    timings[f"closed loop ({3 * len(rigs) * len(MODES)} hexa_sim runs)"] = time.time() - t0

    write_doc(a, result, closed, rigs, friction_study, timings, out)
    print(f"wrote {a.doc}")


def fmt(v, d=3):
    return "-" if v is None else f"{v:.{d}f}"


def write_doc(a, result, closed, rigs, friction_study, timings, out):
    L = []
    w = L.append
    w("# Identification results (generated)\n")
    w("Generated by `/usr/bin/python3 studies/identification_study.py` (method and deviations: "
      "docs/identification.md). Machine shared with other engineers, 2 cores; load average at the end "
      f"of the run: {load_average()}. Recordings and plots: `{out}/` (not in the repository).\n")
    if a.in_process:
        w(f"Experiment: `hexa_sim --experiment identify --legs 1-6 --excite-duration {a.excite_duration:g} "
          f"--seed {a.seed} --profile realistic` (IN PROCESS: the lockstep simulation, same plant and controller "
          f"code, no DDS), free fall: `hexa_sim --experiment free-fall`. ")
    else:
        w(f"Experiment: `hexa_session --experiment identify --legs 1-6 --excite-duration {a.excite_duration:g} "
          f"--seed {a.seed} --profile realistic` (DDS, lockstep), free fall: `hexa_session --experiment free-fall`. ")
    if a.no_calibration:
        w("Kinematic calibration: NOT used (`--no-calibration`: the rig file's nominal joints and "
          "potentiometers). ")
    elif a.calibration:
        w(f"Kinematic calibration: `{a.calibration}` (given). ")
    else:
        w(f"Kinematic calibration: `hexa_session --trajectory calibration --tracker --seed {a.seed}` (DDS) + "
          "`hexa_calibrate`, passed to hexa_identify with `--rig-overlay`. ")
    w(
      f"Identification: `hexa_identify` (GA: Table 7, MaxIt {result['ga_max_iterations']}, nPop "
      f"{result['ga_population']}, {result['threads']} threads, genes for v_s and eq 3's friction force at 0.1, 0.5, 1.2 m/s "
      f"in ranges around the rig file's values (`--ga-space force-at-speeds`); least squares: Ceres). Payload scale "
      f"estimated {result['payload_scale']:.4f} (truth {result['true_payload_scale']}), pressure noise "
      f"estimated {result.get('pressure_noise_pa', 0):.0f} Pa.\n")

    # Per leg Table 8.
    w("## Table 8 per leg: identified (error % against the plant's truth)\n")
    w("`n.i.` = not identifiable from this recording (the objective's curvature along the parameter, "
      "others re-fitted, is below its noise level; the number is the rise of the channel's Z^2 for a "
      "10 % change). Brackets: expected 1-sigma error from noise.\n")
    by_leg = {}
    for s in result["strokes"]:
        by_leg.setdefault(s["leg"], {})[s["stroke"]] = s
    for leg in sorted(by_leg):
        w(f"### Leg {leg}\n")
        w("| parameter | up: truth | up: GA | up: LSQ | down: truth | down: GA | down: LSQ |")
        w("|---|---|---|---|---|---|---|")
        for i, n in enumerate(NAMES):
            row = f"| {n}"
            for stroke in ("extend", "retract"):
                s = by_leg[leg].get(stroke)
                if s is None:
                    row += " | - | - | -"
                    continue
                t = s["truth"][n]
                row += f" | {t:.4g}"
                for m in ("ga", "lsq"):
                    c = s[f"{m}_curvature"]
                    if not c["identifiable"][i]:
                        row += f" | n.i. ({100 * c['increase_profile_10pct'][i]:.2g} %)"
                    else:
                        v = s[m][n]
                        row += f" | {v:.4g} ({100 * (v - t) / abs(t):+.2f}) [{c['standard_error_pct'][i]:.2g}]"
            w(row + " |")
        w("")

    # Targets.
    w("## Against the targets (every leg, both directions)\n")
    w("| parameter | target % | GA worst % | GA met | LSQ worst % | LSQ met | n.i. GA / LSQ (of 12) |")
    w("|---|---|---|---|---|---|---|")
    for i, n in enumerate(NAMES):
        cells = []
        ni = []
        for m in ("ga", "lsq"):
            errs, cnt = [], 0
            for s in result["strokes"]:
                if not s[f"{m}_curvature"]["identifiable"][i]:
                    cnt += 1
                    continue
                t = s["truth"][n]
                errs.append(abs(100 * (s[m][n] - t) / t))
            worst = max(errs) if errs else None
            cells.append(f"{fmt(worst, 2)} | {'-' if worst is None else ('yes' if worst <= TARGET[i] else 'NO')}")
            ni.append(str(cnt))
        w(f"| {n} | {TARGET[i]} | {cells[0]} | {cells[1]} | {' / '.join(ni)} |")
    w("")

    # GA vs LSQ.
    w("## GA (Table 7) against least squares on the same recording\n")
    w("Wall times on 2 cores, machine shared (load above). Z = NRMSE of eq 13.\n")
    w("| leg | direction | samples | Z nominal | Z GA | Z LSQ | GA s | GA evaluations | LSQ s | GA worst err % | LSQ worst err % |")
    w("|---|---|---|---|---|---|---|---|---|---|---|")
    for s in result["strokes"]:
        worst = {}
        for m in ("ga", "lsq"):
            e = [abs(100 * (s[m][n] - s["truth"][n]) / s["truth"][n]) for i, n in enumerate(NAMES)
                 if s[f"{m}_curvature"]["identifiable"][i]]
            worst[m] = max(e) if e else None
        w(f"| {s['leg']} | {s['stroke']} | {s['samples']} | {s['nominal_objective']:.4g} | {s['ga_objective']:.4g} | "
          f"{s['lsq_objective']:.4g} | {s['ga_wall_s']:.2f} | {s['ga_evaluations']} | {s['lsq_wall_s']:.3f} | "
          f"{fmt(worst['ga'], 2)} | {fmt(worst['lsq'], 2)} |")
    w("")

    # Free fall.
    if result.get("free_fall"):
        w("## Free fall (Appendix B) on the same plant\n")
        w("| leg | F_c free fall N | B free fall N s/m | rms residual mm |")
        w("|---|---|---|---|")
        for f in result["free_fall"]:
            w(f"| {f['leg']} | {f['coulomb_n']:.2f} | {f['viscous_n_s_m']:.2f} | {1e3 * f['rms_residual_m']:.2f} |")
        s1 = next(s for s in result["strokes"] if s["stroke"] == "extend")
        w(f"\nTruth (extend stroke, the fall extends the rod): F_s {s1['truth']['F_s']:.2f} N, F_c "
          f"{s1['truth']['F_c']:.2f} N, B {s1['truth']['B']:.2f} N s/m, v_s {s1['truth']['v_s']:.3f} m/s. "
          "Eq 66 has no Stribeck term: the fit's F_c is an effective level and its B absorbs the Stribeck "
          "decay (see docs/identification.md).\n")

    # Friction model study.
    w("## What LuGre friction does to the eq 3 fit (one leg, 60 s, least squares, errors %)\n")
    with open(friction_study) as f:
        L.append(f.read())

    # Closed loop.
    for mode in MODES:
        write_closed_loop(w, mode[0], {(n, seed): v for (m, n, seed), v in closed.items() if m == mode[0]}, rigs)
    w("## Timings of this run\n")
    for k, v in timings.items():
        w(f"- {k}: {v:.0f} s")
    w("")
    with open(a.doc, "w") as f:
        f.write("\n".join(L) + "\n")


def write_closed_loop(w, title, closed, rigs):
    w(f"## Closed loop, {title}: nominal rig vs identified vs the plant's truth (hexa_sim in process, realistic)\n")
    w("Translation RMSE = norm of the X, Y, Z RMSE (cm), rotation the same over roll, pitch, yaw (deg), "
      "against ground truth over the tracking window; leg = mean leg-length RMSE (mm). 'closure' = "
      "1 - |identified - truth| / |nominal - truth| on the translation RMSE: how much of the difference "
      "the truth makes the identified rig reproduces.\n")
    names = [name for name, _ in rigs]
    extra = names[3:]
    w("| trajectory | seed | nominal cm / deg / mm | identified | truth | closure |" + "".join(f" {n} |" for n in extra))
    w("|---|---|---|---|---|---|" + "---|" * len(extra))
    sums = {name: [0.0, 0.0] for name, _ in rigs}
    for traj in TRAJ:
        for seed in (1, 2, 3):
            cells, tr = {}, {}
            for name, _ in rigs:
                r = closed[(name, seed)]["trajectories"][traj]
                t = norm3(r["rmse_vs_truth"][:3]) * 100
                ro = norm3(r["rmse_vs_truth"][3:]) * DEG
                lg = sum(r["leg_rmse_m"]) / 6 * 1000
                tr[name] = t
                sums[name][0] += t
                sums[name][1] += ro
                cells[name] = f"{t:.3f} / {ro:.3f} / {lg:.2f}" + ("" if r["completed"] else " (NOT completed)")
            gap = abs(tr["nominal"] - tr["truth"])
            closure = 1 - abs(tr["identified"] - tr["truth"]) / gap if gap > 0 else None
            w(f"| {traj} | {seed} | {cells['nominal']} | {cells['identified']} | {cells['truth']} | "
              f"{'-' if closure is None else f'{100 * closure:.0f} %'} |" + "".join(f" {cells[n]} |" for n in extra))
    w("")
    # Per trajectory, summed over the seeds: the gap the identified rig closes.
    w("| trajectory | nominal cm (sum of seeds) | identified | truth | closure |")
    w("|---|---|---|---|---|")
    for traj in TRAJ:
        t = {n: sum(norm3(closed[(n, seed)]["trajectories"][traj]["rmse_vs_truth"][:3]) * 100 for seed in (1, 2, 3))
             for n in ("nominal", "identified", "truth")}
        gap = abs(t["nominal"] - t["truth"])
        closure = 1 - abs(t["identified"] - t["truth"]) / gap if gap > 0 else None
        w(f"| {traj} | {t['nominal']:.3f} | {t['identified']:.3f} | {t['truth']:.3f} | "
          f"{'-' if closure is None else f'{100 * closure:.0f} %'} |")
    w("")
    w("| rig | sum of translation RMSE (21 runs) cm | sum of rotation RMSE deg |")
    w("|---|---|---|")
    for name, _ in rigs:
        w(f"| {name} | {sums[name][0]:.3f} | {sums[name][1]:.3f} |")
    w("")


if __name__ == "__main__":
    main()
