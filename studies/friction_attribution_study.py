#!/usr/bin/python3
"""How much of the Table 9 / 10 error is the controllers' friction model, and what is left
with an exact model (docs/measurements/results.md "The controllers' friction model").

Runs the seven paper trajectories in the in-process lockstep simulation (hexa_sim, BS-SMC,
feed-forward on, realistic profile, kinematic calibration first: `--calibrate`), seeds 1-3,
with the controllers and the supervisor given, in turn:
  - the rig file's nominal model (what docs/measurements/results.md's first section reports);
  - the identified model (the overlay of studies/identification_study.py);
  - the plant's true model (the truth overlay the same study writes: friction, polytropic
    indices, gravity loads of the realistic profile);
  - the true model with eq 14's friction estimate scaled by 0.95, 0.90 and 1/1.2 (the last
    one gives the friction magnitudes of the nominal model: the realistic plant's friction is
    the nominal x 1.2);
and, as the floor of the control loop itself, the `ideal` profile (the plant IS the nominal
model: no noise, no mismatch, no calibration error; no --calibrate).
Prints a markdown table: median over the seeds of the 12 cells (moving axis of each pure
motion, the six axes of combined), '*' above one fifth of the paper, and the combined
trajectory's leg RMSE.

Usage:
  /usr/bin/python3 studies/identification_study.py          # writes the two overlays (DDS, ~7 min)
  /usr/bin/python3 studies/friction_attribution_study.py [--build build] [--seeds 1,2,3]
      [--truth-overlay F] [--identified-overlay F] [--jobs 2] [--out out/friction_attribution] > table.md
"""
import argparse
import os
import re
import statistics
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from accuracy_tables import PAPER9, PAPER10, parse_sim_rows  # noqa: E402

HERE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TRAJ = ["x", "y", "z", "roll", "pitch", "yaw"]


def scaled_rig(rig, scale, out_dir):
    """A copy of the rig file whose BS-SMC friction estimate scale is `scale` (a controller
    parameter only: the plant is unchanged)."""
    text = open(rig).read()
    new, n = re.subn(r"(\n\s*friction_estimate_scale:\s*)[-\d.eE+]+", lambda m: m.group(1) + repr(scale), text)
    if n != 1:
        sys.exit(f"{rig}: expected one friction_estimate_scale field, found {n}")
    path = os.path.join(out_dir, f"rig_friction_scale_{scale:.4f}.textproto")
    with open(path, "w") as f:
        f.write(new)
    return path


def run(build, seed, args):
    cmd = [os.path.join(build, "tools", "hexa_sim"), "--controller", "bssmc", "--seed", str(seed)] + args
    out = subprocess.run(cmd, capture_output=True, text=True)
    if out.returncode != 0:
        sys.exit(f"{' '.join(cmd)}: exit {out.returncode}\n{out.stderr}")
    rows = {t: axes + [statistics.mean(legs)] for t, (axes, legs) in parse_sim_rows(out.stdout).items()}
    missing = [t for t in TRAJ + ["combined"] if t not in rows]
    if missing:
        sys.exit(f"{' '.join(cmd)}: no result for {', '.join(missing)} (HOLD?)\n{out.stdout[-2000:]}")
    return rows, " ".join(cmd)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default=os.path.join(HERE, "build"))
    ap.add_argument("--seeds", default="1,2,3")
    ap.add_argument("--rig", default=os.path.join(HERE, "deploy", "rigs", "hexataar_r.textproto"))
    ap.add_argument("--truth-overlay", default=os.path.join(HERE, "out", "identification", "truth_overlay.textproto"))
    ap.add_argument("--identified-overlay",
                    default=os.path.join(HERE, "out", "identification", "identified", "identified.textproto"))
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--out", default=os.path.join(HERE, "out", "friction_attribution"),
                    help="where the scaled rig copies are written (the printed commands use them)")
    a = ap.parse_args()
    for name, path in [("--truth-overlay", a.truth_overlay), ("--identified-overlay", a.identified_overlay)]:
        if not os.path.isfile(path):
            sys.exit(f"{name} {path}: no such file; studies/identification_study.py writes it")
    seeds = [int(s) for s in a.seeds.split(",")]
    os.makedirs(a.out, exist_ok=True)
    cal = ["--calibrate", "--rig"]
    configs = [
        ("nominal model (rig file)", cal + [a.rig]),
        ("identified model (overlay)", cal + [a.rig, "--rig-overlay", a.identified_overlay]),
        ("true model (truth overlay)", cal + [a.rig, "--rig-overlay", a.truth_overlay]),
        ("true model, friction estimate x 0.95", cal + [scaled_rig(a.rig, 0.95, a.out), "--rig-overlay", a.truth_overlay]),
        ("true model, friction estimate x 0.90", cal + [scaled_rig(a.rig, 0.90, a.out), "--rig-overlay", a.truth_overlay]),
        ("true model, friction estimate x 1/1.2 (nominal magnitudes)",
         cal + [scaled_rig(a.rig, 1 / 1.2, a.out), "--rig-overlay", a.truth_overlay]),
        ("ideal profile (plant = nominal model, no noise; no calibration)", ["--rig", a.rig, "--profile", "ideal"]),
    ]
    jobs = [(c, s) for c in range(len(configs)) for s in seeds]
    with ThreadPoolExecutor(max_workers=a.jobs) as ex:
        results = list(ex.map(lambda j: run(a.build, j[1], configs[j[0]][1]), jobs))
    res = {j: r for j, r in zip(jobs, results)}

    print("| controller model | pure x cm | pure y | pure z | pure roll deg | pure pitch | pure yaw | "
          "comb x cm | comb y | comb z | comb roll deg | comb pitch | comb yaw | met of 12 | comb leg RMSE mm |")
    print("|---" * 15 + "|")
    for c, (name, _) in enumerate(configs):
        cells, met = [], 0
        for k, t in enumerate(TRAJ):
            v = statistics.median(res[(c, s)][0][t][k] for s in seeds)
            ok = v <= PAPER9[k] / 5
            met += ok
            cells.append(f"{v:.3f}" + ("" if ok else "*"))
        for k in range(6):
            v = statistics.median(res[(c, s)][0]["combined"][k] for s in seeds)
            ok = v <= PAPER10[k] / 5
            met += ok
            cells.append(f"{v:.3f}" + ("" if ok else "*"))
        leg = statistics.median(res[(c, s)][0]["combined"][6] for s in seeds)
        print(f"| {name} | " + " | ".join(cells) + f" | {met} | {leg:.2f} |")
    print("| one fifth of the paper | " + " | ".join(f"{v / 5:.3f}" for v in PAPER9 + PAPER10) + " | | |")
    print()
    print(f"Median over seeds {', '.join(map(str, seeds))}; '*' = above one fifth of the paper; "
          "comb leg RMSE = mean over the six legs. Commands (seed 1): " +
          "; ".join(f"`{res[(c, seeds[0])][1]}`" for c in range(len(configs))))


if __name__ == "__main__":
    main()
