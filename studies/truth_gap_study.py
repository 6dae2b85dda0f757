#!/usr/bin/env python3
"""Why the BS-SMC with the plant's TRUE pneumatic values tracks worse than with the rig
file's nominal ones (docs/measurements/identification.md, "Why the truth rig tracks worse").

In-process closed loop (hexa_sim: the services' controller, supervisor and plant code, no
DDS), BS-SMC with the default feed-forward, the seven paper trajectories, seeds 1-3; sums over
the 21 runs of the translation and rotation RMSE against ground truth and of the mean leg
RMSE. Rows:
  - realistic plant: nominal rig, the truth overlay, and its friction / polytropic / gravity
    parts alone;
  - plants that differ from the rig file in ONE thing (a rig-file copy with extra profiles:
    sensor noise on, no supply ripple, no calibration errors, payload x1): polytropic x1.1,
    friction x1.2, or nothing; each run with the nominal controller model and with overlays
    that scale the controller's polytropic / friction values;
  - the force-loop gain beta_1 of the BS-SMC (rig-file copies) with the nominal and the truth
    overlay.

    /usr/bin/python3 studies/truth_gap_study.py --truth-overlay out/identification/truth_overlay.textproto

(the truth overlay is written by hexa_identify --truth-overlay, studies/identification_study.py).
"""
import argparse
import json
import math
import os
import re
import subprocess

RIG = "deploy/rigs/hexataar_r.textproto"


def profile(name, friction, polytropic):
    return (f'disturbance_profile {{\n  name: "{name}"\n  sensor_noise: true\n  friction_scale: {friction}\n'
            f'  polytropic_scale: {polytropic}\n  payload_scale: 1\n  supply_ripple_amplitude_pa: 0\n'
            f'  supply_ripple_frequency_hz: 0\n  joint_position_error_max_m: 0\n  potentiometer_offset_max_m: 0\n'
            f'  potentiometer_gain_error_max: 0\n}}\n')


def block(text, name):
    """The numbers of `name { extend {...} retract {...} }` in the rig file."""
    m = re.search(name + r" \{\s*extend \{([^}]*)\}\s*retract \{([^}]*)\}", text)
    parse = lambda body: [(k, float(v)) for k, v in re.findall(r"(\w+): ([-\d.eE+]+)", body)]
    return {"extend": parse(m.group(1)), "retract": parse(m.group(2))}


def scaled_overlay(path, rig_text, what, k):
    """An overlay holding the rig file's friction (magnitudes, not v_s) or polytropic values x k."""
    values = block(rig_text, what)
    lines = ['rig_name: "HexaTaar-R"', f'provenance {{ method: "rig file {what} x {k:g} (truth_gap_study)" date: "-" }}']
    for leg in range(1, 7):
        body = []
        for d, kv in values.items():
            fields = " ".join(f"{n}: {v if n == 'stribeck_velocity_m_s' else v * k!r}" for n, v in kv)
            body.append(f"{d} {{ {fields} }}")
        lines.append(f"leg {{ leg_id: {leg} {what} {{ {' '.join(body)} }} }}")
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")


def part_of(src, dst, keep):
    """A copy of an overlay with only its `keep` blocks (friction, polytropic, gravity_load_n)."""
    out, skipping = [], 0
    for line in open(src):
        s = line.strip()
        if skipping:
            skipping += line.count("{") - line.count("}")
            continue
        if (s.startswith("friction {") or s.startswith("polytropic {")) and s.split()[0] != keep:
            skipping = line.count("{") - line.count("}")
            continue
        if s.startswith("gravity_load_n") and keep != "gravity_load_n":
            continue
        out.append(line)
    with open(dst, "w") as f:
        f.writelines(out)


def run(sim, out, name, args):
    tot = {"trans": 0.0, "rot": 0.0, "leg": 0.0}
    for seed in (1, 2, 3):
        path = os.path.join(out, f"{name}_seed{seed}.json")
        if not os.path.exists(path):
            subprocess.run([sim, "--seed", str(seed), "--json", path] + args, check=True, stdout=subprocess.DEVNULL)
        for r in json.load(open(path))["trajectories"].values():
            tot["trans"] += 100 * math.sqrt(sum(x * x for x in r["rmse_vs_truth"][:3]))
            tot["rot"] += math.degrees(math.sqrt(sum(x * x for x in r["rmse_vs_truth"][3:])))
            tot["leg"] += 1000 * sum(r["leg_rmse_m"]) / 6
    return tot


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--build", default="build")
    ap.add_argument("--out", default="out/truth_gap")
    ap.add_argument("--truth-overlay", required=True, help="hexa_identify --truth-overlay output")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    sim = os.path.join(a.build, "tools", "hexa_sim")
    rig_text = open(RIG).read()
    study_rig = os.path.join(a.out, "rig_profiles.textproto")
    with open(study_rig, "w") as f:
        f.write(rig_text.replace('default_profile: "realistic"',
                                 profile("same", 1, 1) + profile("poly1.1", 1, 1.1) + profile("fric1.2", 1.2, 1)
                                 + 'default_profile: "realistic"'))
    ov = lambda n: os.path.join(a.out, n)
    for keep in ("friction", "polytropic", "gravity_load_n"):
        part_of(a.truth_overlay, ov(f"truth_{keep}.textproto"), keep)
    scaled_overlay(ov("poly_x1.1.textproto"), rig_text, "polytropic", 1.1)
    scaled_overlay(ov("fric_x1.2.textproto"), rig_text, "friction", 1.2)
    scaled_overlay(ov("fric_x0.833.textproto"), rig_text, "friction", 1 / 1.2)
    # beta_1 rows: the rig file's value x 0.9, 1.1, 1.21 (named by factor; the value may change).
    beta_re = re.compile(r"(backstepping_beta_1_s:\s*)([0-9.eE+-]+)")
    found = beta_re.findall(rig_text)
    if len(found) != 1:
        raise SystemExit(f"{RIG}: expected one backstepping_beta_1_s, found {len(found)}")
    beta_nominal = float(found[0][1])
    betas = {}
    for name, factor in (("x0.9", 0.9), ("x1.1", 1.1), ("x1.21", 1.21)):
        betas[name] = beta_nominal * factor
        with open(ov(f"rig_beta{name}.textproto"), "w") as f:
            f.write(beta_re.sub(lambda m: m.group(1) + repr(betas[name]), rig_text))
    rows = [
        ("realistic", "nominal rig", []),
        ("realistic", "truth overlay", ["--rig-overlay", a.truth_overlay]),
        ("realistic", "truth friction only", ["--rig-overlay", ov("truth_friction.textproto")]),
        ("realistic", "truth polytropic only", ["--rig-overlay", ov("truth_polytropic.textproto")]),
        ("realistic", "truth gravity loads only", ["--rig-overlay", ov("truth_gravity_load_n.textproto")]),
        ("polytropic x1.1 only", "nominal (controller gamma = plant / 1.1)", ["--rig", study_rig, "--profile", "poly1.1"]),
        ("polytropic x1.1 only", "exact (gamma x1.1)", ["--rig", study_rig, "--profile", "poly1.1", "--rig-overlay", ov("poly_x1.1.textproto")]),
        ("= rig file", "exact (nominal)", ["--rig", study_rig, "--profile", "same"]),
        ("= rig file", "gamma x1.1 (controller gamma = plant x 1.1)", ["--rig", study_rig, "--profile", "same", "--rig-overlay", ov("poly_x1.1.textproto")]),
        ("friction x1.2 only", "nominal (controller friction = plant / 1.2)", ["--rig", study_rig, "--profile", "fric1.2"]),
        ("friction x1.2 only", "exact (friction x1.2)", ["--rig", study_rig, "--profile", "fric1.2", "--rig-overlay", ov("fric_x1.2.textproto")]),
        ("= rig file", "friction x1.2", ["--rig", study_rig, "--profile", "same", "--rig-overlay", ov("fric_x1.2.textproto")]),
        ("= rig file", "friction / 1.2", ["--rig", study_rig, "--profile", "same", "--rig-overlay", ov("fric_x0.833.textproto")]),
        (f"realistic, beta_1 {betas['x0.9']:g}", "nominal rig", ["--rig", ov("rig_betax0.9.textproto")]),
        (f"realistic, beta_1 {betas['x1.1']:g}", "nominal rig", ["--rig", ov("rig_betax1.1.textproto")]),
        (f"realistic, beta_1 {betas['x1.1']:g}", "truth overlay", ["--rig", ov("rig_betax1.1.textproto"), "--rig-overlay", a.truth_overlay]),
        (f"realistic, beta_1 {betas['x1.21']:g}", "truth overlay", ["--rig", ov("rig_betax1.21.textproto"), "--rig-overlay", a.truth_overlay]),
    ]
    print("| plant | controller model | translation RMSE, sum cm | rotation RMSE, sum deg | mean leg RMSE, sum mm |")
    print("|---|---|---|---|---|")
    for i, (plant, model, args) in enumerate(rows):
        t = run(sim, a.out, f"row{i}", args)
        print(f"| {plant} | {model} | {t['trans']:.3f} | {t['rot']:.3f} | {t['leg']:.2f} |", flush=True)


if __name__ == "__main__":
    main()
