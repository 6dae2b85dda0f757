#!/usr/bin/python3
"""What command authentication costs (docs/faults.md, "Foreign commands"), side by side in one
run: N rounds, each running hexa_session on the combined trajectory with the session key (the
default), with --insecure-commands (no key, nothing signed or checked) and, with --baseline,
another build's hexa_session (the code before the check: EXCLUSIVE ownership, no tag), the order
rotating between rounds so that a change of the machine's load hits every variant alike. Reports per
run and as medians: the lockstep tick's wall time (plant.json tick_wall_s median / p99 / mean),
the loop's speed (simulated s per wall s of the loop), and the CPU time of every process per
simulated second (processes.json; start-up included). The machine may be loaded by other work:
compare within one run only.

Usage: /usr/bin/python3 bench/session/command_auth_cost.py [--build build] [--runs 3]
       [--periods 1] [--mode lockstep|realtime] [--baseline OTHER_BUILD]
(inside a private network namespace, like every DDS benchmark here)
"""
import argparse
import json
import os
import statistics
import subprocess
import sys


def session(build, out, mode, periods, domain, extra):
    cmd = [os.path.join(build, "deploy", "hexa_session"), "--trajectory", "combined",
           "--periods", str(periods), "--mode", mode, "--seed", "1", "--out", out,
           "--domain", str(domain), "--timeout", "600"] + extra
    rc = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL).returncode
    try:
        plant = json.load(open(os.path.join(out, "plant.json")))
        procs = json.load(open(os.path.join(out, "processes.json")))
    except (OSError, ValueError):
        return rc, None
    sim = plant["sim_time_s"]
    key = "tick_wall_s" if mode == "lockstep" else "wake_lateness_s"
    cpu = {p["name"]: (p["cpu_user_s"] + p["cpu_system_s"]) / sim for p in procs["processes"]}
    control = sum(v for k, v in cpu.items() if k.startswith("leg") or k in ("plant", "supervisor"))
    return rc, {
        "tick_median_us": plant[key]["median"] * 1e6,
        "tick_p99_us": plant[key]["p99"] * 1e6,
        "tick_mean_us": plant[key]["mean"] * 1e6,
        "speed": sim / plant["loop_wall_s"] if plant["loop_wall_s"] > 0 else 0.0,
        "cpu_control_s_per_s": control,
        "cpu_plant_s_per_s": cpu.get("plant", 0.0),
        "cpu_legs_s_per_s": sum(v for k, v in cpu.items() if k.startswith("leg")),
        "cpu_all_s_per_s": (procs["cpu_user_s"] + procs["cpu_system_s"]) / sim,
    }


def main():
    here = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default=os.path.join(here, "build"))
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--periods", type=int, default=1)
    ap.add_argument("--mode", choices=["lockstep", "realtime"], default="lockstep")
    ap.add_argument("--baseline", help="also run this build's hexa_session as it is (e.g. one "
                    "built from the commit before command authentication)")
    ap.add_argument("--out", default=os.path.join(here, "out", "bench-command-auth"))
    a = ap.parse_args()
    domain = 200 + os.getpid() % 30
    variants = [("with key", a.build, []), ("without key", a.build, ["--insecure-commands"])]
    if a.baseline:
        variants.append(("baseline", a.baseline, []))
    results = {label: [] for label, _, _ in variants}
    print(f"load average at start: {open('/proc/loadavg').read().split()[:3]}")
    for r in range(a.runs):
        order = variants[r % len(variants):] + variants[:r % len(variants)]  # rotates per round
        for label, build, extra in order:
            out = os.path.join(a.out, f"run{r}-{label.replace(' ', '-')}")
            subprocess.run(["rm", "-rf", out])
            rc, m = session(build, out, a.mode, a.periods, domain, extra)
            if m is None:
                print(f"round {r} {label}: exit {rc}, no figures ({out})")
                continue
            results[label].append(m)
            print(f"round {r} {label:11s}: exit {rc} tick median {m['tick_median_us']:.1f} us "
                  f"p99 {m['tick_p99_us']:.1f} us mean {m['tick_mean_us']:.1f} us, "
                  f"speed {m['speed']:.2f}x, CPU per simulated s: control "
                  f"{m['cpu_control_s_per_s']:.3f} (plant {m['cpu_plant_s_per_s']:.3f}, legs "
                  f"{m['cpu_legs_s_per_s']:.3f}), all {m['cpu_all_s_per_s']:.3f} s")
            sys.stdout.flush()
    print(f"load average at end: {open('/proc/loadavg').read().split()[:3]}")
    for label, _, _ in variants:
        runs = results[label]
        if not runs:
            continue
        med = {k: statistics.median(m[k] for m in runs) for k in runs[0]}
        print(f"median of {len(runs)} {label:11s}: tick median "
              f"{med['tick_median_us']:.1f} us p99 {med['tick_p99_us']:.1f} us mean "
              f"{med['tick_mean_us']:.1f} us, speed {med['speed']:.2f}x, CPU per simulated s: "
              f"control {med['cpu_control_s_per_s']:.3f} (plant {med['cpu_plant_s_per_s']:.3f}, "
              f"legs {med['cpu_legs_s_per_s']:.3f}), all {med['cpu_all_s_per_s']:.3f} s")


if __name__ == "__main__":
    main()
