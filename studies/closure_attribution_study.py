#!/usr/bin/python3
"""How much of the closed-loop 'closure' figure is noise, and which identified parameters drive
the identified rig's distance from the truth rig (docs/measurements/identification.md,
"The closed-loop row: sensitivity floor and attribution").

In-process closed loop (hexa_sim: the services' controller, supervisor and plant code, no DDS),
`realistic`, BS-SMC, the seven paper trajectories, seeds 1-3, in both modes of
studies/identification_study.py (with the platform feed-forward, and paper-faithful
--no-feedforward). Per trajectory the translation RMSE against ground truth summed over the
seeds, as the study's closure table.

  1. Sensitivity floor: the truth overlay with every friction, polytropic and gravity-load value
     multiplied by (1 + u), u uniform in [-p, p] and drawn independently per value (numpy
     default_rng(draw), draws 1..N); the spread of the per-trajectory sums over the draws is
     what a model change of that size does to the figure.
  2. Attribution: the truth overlay with ONE group's identified value swapped in (v_s, B, F_s,
     F_c, the three gammas; per direction; and the gravity loads), and the converse: the
     identified overlay with one group's TRUE value swapped in. Where the identified overlay
     has no value (a parameter reported not identifiable), the rig file's value is used, as
     the controllers do.
  3. --seed-triples N: the nominal, identified and truth rigs also with seeds 1..3N, the closure
     per seed triple and over all.

    /usr/bin/python3 studies/closure_attribution_study.py \
        --truth-overlay out/identification/truth_overlay.textproto \
        --identified-overlay out/identification/identified/identified.textproto

Writes out/closure_attribution/summary.json and prints markdown tables.
"""
import argparse
import hashlib
import json
import math
import os
import re
import statistics
import subprocess
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from identification_study import MODES, TRAJ, norm3  # noqa: E402

RIG = "deploy/rigs/hexataar_r.textproto"
DIRECTIONS = ("extend", "retract")
# Parameter groups (overlay field names; docs/identification.md names them v_s, B, F_s, F_c, gamma_*).
GROUPS = {
    "v_s": ("friction", ["stribeck_velocity_m_s"]),
    "B": ("friction", ["viscous_n_s_m"]),
    "F_s": ("friction", ["static_n"]),
    "F_c": ("friction", ["coulomb_n"]),
    "gammas": ("polytropic", ["inflow", "outflow", "volume"]),
}


# --- A minimal protobuf text format reader / writer (the overlays' subset: scalars, nested
# --- messages, repeated `leg`); keeps field order.
def parse_text(text):
    tokens = re.findall(r'"(?:[^"\\]|\\.)*"|[{}]|[A-Za-z_][\w]*\s*:?|[-+0-9.eE]+', re.sub(r"#[^\n]*", "", text))
    pos = 0

    def msg():
        nonlocal pos
        fields = []
        while pos < len(tokens) and tokens[pos] != "}":
            name = tokens[pos].rstrip(": \t")
            pos += 1
            if tokens[pos] == "{":
                pos += 1
                fields.append((name, msg()))
                pos += 1  # "}"
            else:
                v = tokens[pos]
                pos += 1
                fields.append((name, v if v.startswith('"') else float(v)))
        return fields

    return msg()


def write_text(fields, indent=0):
    pad = "  " * indent
    out = []
    for name, v in fields:
        if isinstance(v, list):
            out.append(f"{pad}{name} {{")
            out.append(write_text(v, indent + 1))
            out.append(f"{pad}}}")
        elif isinstance(v, str):
            out.append(f"{pad}{name}: {v}")
        else:
            out.append(f"{pad}{name}: {int(v) if name == 'leg_id' else repr(float(v))}")
    return "\n".join(x for x in out if x)


def get(fields, name):
    for n, v in fields:
        if n == name:
            return v
    return None


def legs(overlay):
    return {int(get(leg, "leg_id")): leg for n, leg in overlay if n == "leg"}


def value(leg, block, direction, field):
    b = get(leg, block)
    d = get(b, direction) if b else None
    return get(d, field) if d else None


def set_value(leg, block, direction, field, v):
    b = get(leg, block)
    if b is None:
        b = []
        leg.append((block, b))
    d = get(b, direction)
    if d is None:
        d = []
        b.append((direction, d))
    for i, (n, _) in enumerate(d):
        if n == field:
            d[i] = (n, v)
            return
    d.append((field, v))


def rig_values(rig_text):
    """The rig file's friction and polytropic values: {(block, direction, field): value}."""
    out = {}
    for block in ("friction", "polytropic"):
        m = re.search(r"\n" + block + r" \{\s*extend \{([^}]*)\}\s*retract \{([^}]*)\}", rig_text)
        for direction, body in zip(DIRECTIONS, m.groups()):
            for k, v in re.findall(r"(\w+): ([-\d.eE+]+)", body):
                out[(block, direction, k)] = float(v)
    return out


def copy(fields):
    return [(n, copy(v) if isinstance(v, list) else v) for n, v in fields]


def with_provenance(overlay, text):
    o = copy(overlay)
    for i, (n, v) in enumerate(o):
        if n == "provenance":
            o[i] = ("provenance", [("method", json.dumps(text)), ("date", '"-"'), ("tool", '"closure_attribution_study"')])
    return o


def perturbation_factors(draw, p):
    """Factors 1 + U(-p, p) per (leg, block, direction, field) and per leg's gravity load, drawn
    in one fixed order (numpy default_rng(draw)): the same factors for every overlay of a draw."""
    rng = np.random.default_rng(draw)
    keys = []
    for leg_id in range(1, 7):
        for block, fields in (("friction", ["stribeck_velocity_m_s", "viscous_n_s_m", "static_n", "coulomb_n"]),
                              ("polytropic", ["inflow", "outflow", "volume"])):
            keys += [(leg_id, block, d, f) for d in DIRECTIONS for f in fields]
        keys.append((leg_id, "gravity_load_n", "", ""))
    return {k: 1 + rng.uniform(-p, p) for k in keys}


def perturbed(overlay, factors, label):
    """Every friction, polytropic and gravity-load value of `overlay` (complete: every field
    present) times its factor."""
    o = with_provenance(overlay, label)
    for leg_id, leg in legs(o).items():
        for block in ("friction", "polytropic"):
            for direction in DIRECTIONS:
                d = get(get(leg, block), direction)
                for i, (n, v) in enumerate(d):
                    d[i] = (n, v * factors[(leg_id, block, direction, n)])
        for i, (n, v) in enumerate(leg):
            if n == "gravity_load_n":
                leg[i] = (n, v * factors[(leg_id, "gravity_load_n", "", "")])
    return o


def nominal_overlay(rig, gravity_load_n):
    """The rig file's values written out as an overlay (so that they can be perturbed)."""
    o = [("rig_name", '"HexaTaar-R"'), ("provenance", [])]
    for leg_id in range(1, 7):
        leg = [("leg_id", leg_id)]
        for (block, direction, f), v in rig.items():
            set_value(leg, block, direction, f, v)
        leg.append(("gravity_load_n", gravity_load_n))
        o.append(("leg", leg))
    return with_provenance(o, "the rig file's friction, polytropic and gravity-load values")


def swapped(base, source, rig, group, direction, label):
    """`base` with `group` (per `direction`, or the gravity loads) taken from `source`; where
    `source` has no value, the rig file's (what the controllers use then)."""
    o = with_provenance(base, label)
    src = legs(source)
    for leg_id, leg in legs(o).items():
        if group == "gravity":
            for i, (n, v) in enumerate(leg):
                if n == "gravity_load_n":
                    leg[i] = (n, get(src[leg_id], "gravity_load_n"))
            continue
        block, fields = GROUPS[group]
        for f in fields:
            v = value(src[leg_id], block, direction, f)
            set_value(leg, block, direction, f, rig[(block, direction, f)] if v is None else v)
    return o


def completed(overlay, rig):
    """The overlay with every friction / polytropic value present (the rig file's where absent)."""
    o = copy(overlay)
    for leg in legs(o).values():
        for (block, direction, f), v in rig.items():
            if value(leg, block, direction, f) is None:
                set_value(leg, block, direction, f, v)
    return o


def run_sums(sim, out, overlay_path, mode, seeds=(1, 2, 3)):
    """Per trajectory, translation RMSE (cm) summed over seeds 1-3; and the values per seed of
    `seeds` (which start with 1, 2, 3).
    Runs are cached in `out` under the overlay's content hash."""
    key = "none"
    if overlay_path:
        with open(overlay_path, "rb") as f:
            key = hashlib.sha1(f.read()).hexdigest()[:12]
    sums, per_seed = {t: 0.0 for t in TRAJ}, {t: [] for t in TRAJ}
    for seed in seeds:
        path = os.path.join(out, "runs", f"{mode[1] or 'ff_'}{key}_seed{seed}.json")
        if not os.path.exists(path):
            cmd = [sim, "--seed", str(seed), "--json", path + ".tmp"] + mode[2]
            if overlay_path:
                cmd += ["--rig-overlay", overlay_path]
            subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
            os.replace(path + ".tmp", path)
        with open(path) as f:
            r = json.load(f)["trajectories"]
        for t in TRAJ:
            if not r[t]["completed"]:
                raise SystemExit(f"{path}: trajectory {t} not completed")
            v = 100 * norm3(r[t]["rmse_vs_truth"][:3])
            sums[t] += v if seed <= 3 else 0.0
            per_seed[t].append(v)
    return sums, per_seed


def closure(nominal, identified, truth):
    return 1 - abs(identified - truth) / abs(nominal - truth)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--build", default="build")
    ap.add_argument("--out", default="out/closure_attribution")
    ap.add_argument("--truth-overlay", required=True)
    ap.add_argument("--identified-overlay", required=True)
    ap.add_argument("--draws", type=int, default=10)
    ap.add_argument("--perturbation", type=float, default=0.005, help="p of U(-p, p)")
    ap.add_argument("--seed-triples", type=int, default=1,
                    help="also run the nominal, identified and truth rigs with seeds 1..3N and print the "
                         "closure per seed triple (1-3, 4-6, ...) and over all")
    ap.add_argument("--skip", default="", help="comma list of parts to skip: floor, swap-in, swap-out")
    a = ap.parse_args()
    os.makedirs(os.path.join(a.out, "runs"), exist_ok=True)
    sim = os.path.join(a.build, "tools", "hexa_sim")
    with open(RIG) as f:
        rig_text = f.read()
    rig = rig_values(rig_text)
    gravity = re.findall(r"\bgravity_load_n:\s*([-\d.eE+]+)", rig_text)
    if len(gravity) != 1:
        raise SystemExit(f"{RIG}: expected one gravity_load_n, found {len(gravity)}")
    with open(a.truth_overlay) as f:
        truth = parse_text(f.read())
    with open(a.identified_overlay) as f:
        identified = parse_text(f.read())
    complete_identified = completed(identified, rig)
    skip = set(filter(None, a.skip.split(",")))

    def write(name, overlay):
        path = os.path.join(a.out, name + ".textproto")
        text = write_text(overlay) + "\n"
        if not os.path.exists(path) or open(path).read() != text:
            with open(path, "w") as f:
                f.write(text)
        return path

    variants = [("nominal", None), ("truth", write("truth", truth)), ("identified", write("identified", identified))]
    if "floor" not in skip:
        nominal = nominal_overlay(rig, float(gravity[0]))
        variants.append(("nominal as overlay", write("nominal_as_overlay", nominal)))  # check: = nominal
        for k in range(1, a.draws + 1):
            fac = perturbation_factors(k, a.perturbation)
            label = f"x (1 + U(-{a.perturbation:g}, {a.perturbation:g})), draw {k}"
            for name, o in (("truth", truth), ("identified", complete_identified), ("nominal", nominal)):
                variants.append((f"{name}~{k}", write(f"{name}~{k}", perturbed(o, fac, f"{name} overlay {label}"))))
    groups = [(g, d) for g in GROUPS for d in DIRECTIONS] + [("gravity", "")]
    for g, d in groups:
        tag = f"{g}_{d}" if d else g
        if "swap-in" not in skip:
            variants.append((f"truth+id_{tag}", write(f"truth+id_{tag}", swapped(truth, identified, rig, g, d,
                                                                                 f"truth overlay, identified {tag}"))))
        if "swap-out" not in skip:
            variants.append((f"id+truth_{tag}", write(f"id+truth_{tag}", swapped(complete_identified, truth, rig, g, d,
                                                                                 f"identified overlay, true {tag}"))))
    results = {}
    for mode in MODES:
        for name, path in variants:
            seeds = range(1, 3 * a.seed_triples + 1) if name in ("nominal", "identified", "truth") else (1, 2, 3)
            sums, per_seed = run_sums(sim, a.out, path, mode, seeds)
            results[f"{mode[1]}{name}"] = {"sums": sums, "per_seed": per_seed}
            print(f"{mode[1] or 'ff_'}{name}: " + " ".join(f"{t} {sums[t]:.3f}" for t in TRAJ), file=sys.stderr, flush=True)
    with open(os.path.join(a.out, "summary.json"), "w") as f:
        json.dump({"draws": a.draws, "perturbation": a.perturbation, "results": results}, f, indent=1)
    report(results, a, groups, skip)


def report(results, a, groups, skip):
    for mode in MODES:
        m = mode[1]
        R = lambda n: results[m + n]["sums"]
        print(f"\n### {mode[0]}\n")
        if a.seed_triples > 1:
            P = lambda n, t, lo, hi: sum(results[m + n]["per_seed"][t][lo:hi])
            print("Closure per seed triple (unperturbed rigs; translation RMSE summed over the triple's seeds), "
                  f"and over seeds 1-{3 * a.seed_triples} (sums in cm: nominal / identified / truth).\n")
            trip = [(3 * i, 3 * i + 3) for i in range(a.seed_triples)]
            print("| trajectory | " + " | ".join(f"seeds {lo + 1}-{hi}" for lo, hi in trip)
                  + f" | seeds 1-{3 * a.seed_triples} | sums |")
            print("|---|" + "---|" * (len(trip) + 2))
            for t in TRAJ:
                cells = [f"{100 * closure(*(P(n, t, lo, hi) for n in ('nominal', 'identified', 'truth'))):.0f} %"
                         for lo, hi in trip + [(0, 3 * a.seed_triples)]]
                sums = " / ".join(f"{P(n, t, 0, 3 * a.seed_triples):.3f}" for n in ("nominal", "identified", "truth"))
                print(f"| {t} | " + " | ".join(cells) + f" | {sums} |")
            print()
        if "floor" not in skip:
            ks = range(1, a.draws + 1)
            print(f"Floor: {a.draws} draws, every friction, polytropic and gravity-load value x (1 + U(-{a.perturbation:g}, "
                  f"{a.perturbation:g})), the same factors for the three rigs in a draw; translation RMSE summed over "
                  "seeds 1-3, cm. sd = standard deviation over the draws; gap = abs(nominal - truth), miss = "
                  "abs(identified - truth), both unperturbed.\n")
            print("| trajectory | nominal | identified | truth | sd nominal | sd identified | sd truth | truth min-max | "
                  "gap | gap / sd truth | miss | miss / sd truth | closure | closure per draw: median (min to max) | "
                  "identified - truth per draw: mean (sd) | closure of the draw means |")
            print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
            for t in TRAJ:
                d = {n: [R(f"{n}~{k}")[t] for k in ks] for n in ("nominal", "identified", "truth")}
                sd = {n: statistics.stdev(v) for n, v in d.items()}
                nom, ide, tru = R("nominal")[t], R("identified")[t], R("truth")[t]
                gap, miss = abs(nom - tru), abs(ide - tru)
                diff = [d["identified"][i] - d["truth"][i] for i in range(a.draws)]
                cl = sorted(closure(d["nominal"][i], d["identified"][i], d["truth"][i]) for i in range(a.draws))
                print(f"| {t} | {nom:.3f} | {ide:.3f} | {tru:.3f} | {sd['nominal']:.3f} | {sd['identified']:.3f} | "
                      f"{sd['truth']:.3f} | {min(d['truth']):.3f}-{max(d['truth']):.3f} | {gap:.3f} | {gap / sd['truth']:.1f} | "
                      f"{miss:.3f} | {miss / sd['truth']:.1f} | {100 * closure(nom, ide, tru):.0f} % | "
                      f"{100 * statistics.median(cl):.0f} % ({100 * cl[0]:.0f} to {100 * cl[-1]:.0f} %) | "
                      f"{statistics.mean(diff):+.3f} ({statistics.stdev(diff):.3f}) | "
                      f"{100 * closure(*(statistics.mean(d[n]) for n in ('nominal', 'identified', 'truth'))):.0f} % |")
            same = all(R("nominal as overlay")[t] == R("nominal")[t] for t in TRAJ)
            print(f"\nCheck: the rig file's values written as an overlay reproduce the nominal rig: {'yes' if same else 'NO'}.\n")
        if {"swap-in", "swap-out"} <= skip:
            continue
        print("Attribution (cm, translation RMSE summed over seeds 1-3): truth overlay with the identified value of "
              "one group (`truth + id`), minus the truth rig; identified overlay with the true value of one group "
              "(`id + truth`), minus the identified rig. Top row: identified - truth.\n")
        print("| swap | " + " | ".join(TRAJ) + " |")
        print("|---|" + "---|" * len(TRAJ))
        print("| identified - truth | " + " | ".join(f"{R('identified')[t] - R('truth')[t]:+.3f}" for t in TRAJ) + " |")
        for g, d in groups:
            tag = f"{g}_{d}" if d else g
            if "swap-in" not in skip:
                print(f"| truth + id {tag} | " + " | ".join(f"{R('truth+id_' + tag)[t] - R('truth')[t]:+.3f}" for t in TRAJ) + " |")
            if "swap-out" not in skip:
                print(f"| id + truth {tag} | " + " | ".join(f"{R('id+truth_' + tag)[t] - R('identified')[t]:+.3f}" for t in TRAJ) + " |")


if __name__ == "__main__":
    main()
