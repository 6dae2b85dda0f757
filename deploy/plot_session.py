#!/usr/bin/python3
"""Plots of a session, of the kinds in the paper (Figs 8-30), from the CSV time series
that `hexa_recorder report` writes into the output directory:

  pose.csv : time_s, desired_{x,y,z}_m, desired_{roll,pitch,yaw}_rad,
             true_{...} (ground truth), measured_{...} (GQFK + IMU estimate)
  legs.csv : time_s, desired_length_m_{1..6}, measured_length_m_{1..6}, valve_v_{1..6},
             friction_scale_{1..6} (BS-SMC theta; not plotted)

Usage: /usr/bin/python3 plot_session.py OUTPUT_DIR [--title TEXT]
Run with Debian's /usr/bin/python3 (python3-numpy, python3-matplotlib)."""
import argparse
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

AXES = ["x", "y", "z", "roll", "pitch", "yaw"]


def load(path):
    if not os.path.exists(path):
        sys.exit(f"plot_session: missing {path}")
    data = np.genfromtxt(path, delimiter=",", names=True)
    if data.size == 0:
        sys.exit(f"plot_session: {path} has no rows")
    return data


def scale(axis):
    # Task-space plots in the paper's units: cm and deg.
    return (100.0, "cm") if axis in ("x", "y", "z") else (180.0 / np.pi, "deg")


def plot_axes(pose, out, title):
    fig, axs = plt.subplots(3, 2, figsize=(12, 10), sharex=True)
    for i, axis in enumerate(AXES):
        ax = axs[i % 3][i // 3]
        k, unit = scale(axis)
        t = pose["time_s"]
        ax.plot(t, k * pose[f"desired_{axis}"], "k--", lw=1.2, label="desired")
        ax.plot(t, k * pose[f"true_{axis}"], "C0", lw=1.0, label="tracked (ground truth)")
        ax.plot(t, k * pose[f"measured_{axis}"], "C1", lw=0.8, alpha=0.8,
                label="measured (GQFK + IMU)")
        ax.set_ylabel(f"{axis} [{unit}]")
        ax.grid(True, alpha=0.3)
    for ax in axs[-1]:
        ax.set_xlabel("time [s]")
    axs[0][0].legend(loc="upper right", fontsize=8)
    fig.suptitle(f"{title}: desired vs tracked pose (cf. paper Figs 8-13, 21-23)")
    fig.tight_layout()
    fig.savefig(os.path.join(out, "pose_tracking.png"), dpi=110)
    plt.close(fig)

    fig, axs = plt.subplots(3, 2, figsize=(12, 10), sharex=True)
    for i, axis in enumerate(AXES):
        ax = axs[i % 3][i // 3]
        k, unit = scale(axis)
        t = pose["time_s"]
        ax.plot(t, k * (pose[f"desired_{axis}"] - pose[f"true_{axis}"]), "C0", lw=0.8,
                label="desired - ground truth")
        ax.plot(t, k * (pose[f"desired_{axis}"] - pose[f"measured_{axis}"]), "C1", lw=0.8,
                alpha=0.7, label="desired - measured")
        ax.set_ylabel(f"error {axis} [{unit}]")
        ax.grid(True, alpha=0.3)
    for ax in axs[-1]:
        ax.set_xlabel("time [s]")
    axs[0][0].legend(loc="upper right", fontsize=8)
    fig.suptitle(f"{title}: task-space tracking error")
    fig.tight_layout()
    fig.savefig(os.path.join(out, "pose_error.png"), dpi=110)
    plt.close(fig)


def plot_legs(legs, out, title):
    fig, axs = plt.subplots(3, 2, figsize=(12, 10), sharex=True)
    t = legs["time_s"]
    for leg in range(1, 7):
        ax = axs[(leg - 1) % 3][(leg - 1) // 3]
        ax.plot(t, 1000 * legs[f"desired_length_m_{leg}"], "k--", lw=1.2, label="desired")
        ax.plot(t, 1000 * legs[f"measured_length_m_{leg}"], "C0", lw=0.9,
                label="measured (potentiometer)")
        ax.set_ylabel(f"leg {leg} length [mm]")
        ax.grid(True, alpha=0.3)
    for ax in axs[-1]:
        ax.set_xlabel("time [s]")
    axs[0][0].legend(loc="upper right", fontsize=8)
    fig.suptitle(f"{title}: desired vs measured leg lengths (cf. paper Figs 24-29)")
    fig.tight_layout()
    fig.savefig(os.path.join(out, "leg_lengths.png"), dpi=110)
    plt.close(fig)

    fig, axs = plt.subplots(3, 2, figsize=(12, 10), sharex=True)
    for leg in range(1, 7):
        ax = axs[(leg - 1) % 3][(leg - 1) // 3]
        ax.plot(t, legs[f"valve_v_{leg}"], "C2", lw=0.6)
        ax.axhline(5.0, color="k", lw=0.6, ls=":")
        ax.set_ylim(-0.3, 10.3)
        ax.set_ylabel(f"leg {leg} valve [V]")
        ax.grid(True, alpha=0.3)
    for ax in axs[-1]:
        ax.set_xlabel("time [s]")
    fig.suptitle(f"{title}: valve commands, null (closed) at 5 V (cf. paper Figs 14-19, 30)")
    fig.tight_layout()
    fig.savefig(os.path.join(out, "valve_voltages.png"), dpi=110)
    plt.close(fig)


def plot_path(pose, out, title):
    fig = plt.figure(figsize=(8, 7))
    ax = fig.add_subplot(projection="3d")
    ax.plot(100 * pose["desired_x"], 100 * pose["desired_y"], 100 * pose["desired_z"],
            "k--", lw=1.0, label="desired")
    ax.plot(100 * pose["true_x"], 100 * pose["true_y"], 100 * pose["true_z"], "C0", lw=0.9,
            label="tracked (ground truth)")
    ax.set_xlabel("x [cm]")
    ax.set_ylabel("y [cm]")
    ax.set_zlabel("z [cm]")
    ax.legend(loc="upper left", fontsize=8)
    ax.set_title(f"{title}: 3-D path of the platform origin (cf. paper Fig. 20)")
    fig.tight_layout()
    fig.savefig(os.path.join(out, "path_3d.png"), dpi=110)
    plt.close(fig)


def main():
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("out_dir")
    parser.add_argument("--title", default="session")
    args = parser.parse_args()
    pose = load(os.path.join(args.out_dir, "pose.csv"))
    legs = load(os.path.join(args.out_dir, "legs.csv"))
    plot_axes(pose, args.out_dir, args.title)
    plot_legs(legs, args.out_dir, args.title)
    plot_path(pose, args.out_dir, args.title)
    print("plot_session: wrote pose_tracking.png pose_error.png leg_lengths.png "
          "valve_voltages.png path_3d.png")


if __name__ == "__main__":
    main()
