#!/usr/bin/python3
"""Real-time sessions on the simulated device and on the remote-board device, side by side.

Runs hexa_session --mode realtime (or --mode lockstep; combined trajectory, --periods 1) alternately with
--device sim and --device board, N times each, and prints per run: exit code, the 1-minute
load average before the run, the task-space RMSE against the measured pose (GQFK + IMU: the
board's plant publishes no ground truth, so both devices are compared on it), the plant's
control round trip (a sample read from the device -> the valve command computed from it written
to the device: on the board, sensor frame in -> command frame out), the DDS round trip the
recording shows (sensor sample written -> valve command written) and the ticks without a new
sample. Then the median of each over the runs and the ratio board / sim.

Run inside a network namespace as root (SCHED_FIFO), e.g.
  /work/nsrun rig /usr/bin/python3 bench/rig/rig_compare.py --build build --runs 3
hexa_session pins Cyclone to loopback (deploy/cyclonedds-loopback.xml); the emulator listens
on 127.0.0.1. docs/measurements/rig.md has the figures.
"""
import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile


def run_once(build, mode, device, seed, domain, out):
    load = os.getloadavg()[0]
    cmd = [os.path.join(build, "deploy", "hexa_session"), "--mode", mode, "--device", device,
           "--trajectory", "combined", "--periods", "1", "--seed", str(seed), "--domain", str(domain),
           "--out", out, "--hold-timeout", "1", "--timeout", "300"]
    with open(os.path.join(out + ".console"), "w") as console:
        rc = subprocess.call(cmd, stdout=console, stderr=subprocess.STDOUT)
    row = {"device": device, "rc": rc, "load1": load}
    try:
        report = json.load(open(os.path.join(out, "report.json")))
        plant = json.load(open(os.path.join(out, "plant.json")))
    except (OSError, ValueError) as e:
        row["error"] = str(e)
        return row
    row["state"] = report["final_supervisor_state"]
    rm = report["rmse_vs_measured_pose"]
    if any(rm[k] is None for k in rm) or report["tracking_pose_samples"] == 0:
        row["error"] = f"no tracking error: final state {row['state']} (session.log says why)"
        return row
    row["rmse_xyz_mm"] = [1000 * rm[k] for k in ("x_m", "y_m", "z_m")]
    row["rmse_rpy_mrad"] = [1000 * rm[k] for k in ("roll_rad", "pitch_rad", "yaw_rad")]
    row["rmse_pos_norm_mm"] = sum(v * v for v in row["rmse_xyz_mm"]) ** 0.5
    rt = plant["control_round_trip_s"]
    row["device_rt_median_ms"] = 1000 * rt["median"]
    row["device_rt_p99_ms"] = 1000 * rt["p99"]
    dds = report["control_round_trip_latency_s"]
    row["dds_rt_median_ms"] = 1000 * dds["median"]
    row["dds_rt_p99_ms"] = 1000 * dds["p99"]
    row["no_sample_ticks"] = plant.get("ticks_without_sample", 0)
    row["board_link"] = plant.get("board_link", "")
    return row


def fmt(row):
    if "error" in row:
        return f"{row['device']:5} rc {row['rc']} load {row['load1']:.1f}: {row['error']}"
    return (f"{row['device']:5} rc {row['rc']} load {row['load1']:5.1f} {row['state']:5} "
            f"RMSE xyz {row['rmse_xyz_mm'][0]:.2f}/{row['rmse_xyz_mm'][1]:.2f}/{row['rmse_xyz_mm'][2]:.2f} mm "
            f"(norm {row['rmse_pos_norm_mm']:.2f}) rpy {row['rmse_rpy_mrad'][0]:.2f}/"
            f"{row['rmse_rpy_mrad'][1]:.2f}/{row['rmse_rpy_mrad'][2]:.2f} mrad | device round trip "
            f"median {row['device_rt_median_ms']:.3f} p99 {row['device_rt_p99_ms']:.3f} ms | DDS "
            f"median {row['dds_rt_median_ms']:.3f} p99 {row['dds_rt_p99_ms']:.3f} ms | ticks without "
            f"a sample {row['no_sample_ticks']} {row['board_link']}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--build", default="build", help="build directory")
    ap.add_argument("--runs", type=int, default=3, help="runs per device")
    ap.add_argument("--seed", type=int, default=3)
    ap.add_argument("--domain", type=int, default=58)
    ap.add_argument("--keep", help="keep the sessions' outputs in this directory")
    ap.add_argument("--mode", choices=("realtime", "lockstep"), default="realtime",
                    help="lockstep: the same comparison, deterministic (one run is enough)")
    a = ap.parse_args()
    root = a.keep or tempfile.mkdtemp(prefix="rig_compare.")
    os.makedirs(root, exist_ok=True)
    rows = []
    try:
        for k in range(a.runs):
            for device in ("sim", "board"):
                row = run_once(a.build, a.mode, device, a.seed, a.domain,
                               os.path.join(root, f"{device}{k + 1}"))
                print(fmt(row), flush=True)
                rows.append(row)
    finally:
        if not a.keep:
            shutil.rmtree(root, ignore_errors=True)
    print()
    med = {}
    for device in ("sim", "board"):
        ok = [r for r in rows if r["device"] == device and "error" not in r]
        if not ok:
            print(f"{device}: no run with a report")
            continue
        med[device] = {k: statistics.median(r[k] for r in ok)
                       for k in ("rmse_pos_norm_mm", "device_rt_median_ms", "device_rt_p99_ms",
                                 "dds_rt_median_ms", "dds_rt_p99_ms", "load1")}
        m = med[device]
        print(f"{device:5} median of {len(ok)} runs: RMSE position norm {m['rmse_pos_norm_mm']:.2f} mm; "
              f"device round trip median {m['device_rt_median_ms']:.3f} ms, p99 {m['device_rt_p99_ms']:.3f} ms; "
              f"DDS round trip median {m['dds_rt_median_ms']:.3f} ms, p99 {m['dds_rt_p99_ms']:.3f} ms; "
              f"load {m['load1']:.1f}")
    if "sim" in med and "board" in med:
        ratio = med["board"]["rmse_pos_norm_mm"] / med["sim"]["rmse_pos_norm_mm"]
        print(f"RMSE board / sim: {ratio:.3f} (target: within 1.10)")
    return 0 if all(r.get("rc") == 0 for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
