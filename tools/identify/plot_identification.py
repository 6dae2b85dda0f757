#!/usr/bin/python3
"""Plots of hexa_identify's output directory (docs/identification.md):

  predictions_leg<L>.png   measured against model-predicted x'', dP1/dt, dP2/dt (least-squares
                           parameters), a time excerpt and a measured-vs-model scatter per
                           stroke direction
  ga_convergence.png       best NRMSE (eq 13) per GA iteration, every leg and direction
  parameter_errors.png     identified minus true, % (GA and least squares), when the recording
                           carries the plant's truth

Usage: /usr/bin/python3 tools/identify/plot_identification.py OUT_DIR
"""
import csv
import glob
import json
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

NAMES = ["v_s", "B", "F_s", "F_c", "gamma_o", "gamma_i", "gamma_k"]


def read_csv(path):
    with open(path) as f:
        rows = list(csv.DictReader(f))
    return {k: [float(r[k]) for r in rows] for k in rows[0].keys()} if rows else {}


def excerpt(d, seconds=1.5):
    """The first contiguous stretch (gaps of < 5 ticks) of up to `seconds`."""
    ticks = d["tick"]
    if not ticks:
        return slice(0, 0)
    start = len(ticks) // 3
    end = start
    while end + 1 < len(ticks) and ticks[end + 1] - ticks[end] < 5 and ticks[end + 1] - ticks[start] < seconds * 1000:
        end += 1
    return slice(start, end + 1)


def plot_predictions(out_dir, leg):
    files = {s: os.path.join(out_dir, f"predictions_leg{leg}_{s}.csv") for s in ("extend", "retract")}
    data = {s: read_csv(p) for s, p in files.items() if os.path.exists(p)}
    if not data:
        return
    channels = [("accel", "x'' [m/s²]", 1.0), ("p1_rate", "dP1/dt [bar/s]", 1e-5), ("p2_rate", "dP2/dt [bar/s]", 1e-5)]
    fig, axes = plt.subplots(3, 2 * len(data), figsize=(6 * len(data) + 2, 9))
    if len(data) == 1:
        axes = [[a] for a in axes]
    for col, (stroke, d) in enumerate(sorted(data.items())):
        sl = excerpt(d)
        t = [x * 1e-3 for x in d["tick"][sl]]
        for row, (name, label, scale) in enumerate(channels):
            meas = d[f"{name}_meas_m_s2" if name == "accel" else f"{name}_meas_pa_s"]
            model = d[f"{name}_model_m_s2" if name == "accel" else f"{name}_model_pa_s"]
            ax = axes[row][2 * col]
            ax.plot(t, [m * scale for m in meas[sl]], label="measured (eq 40)", lw=1)
            ax.plot(t, [m * scale for m in model[sl]], label="model (least squares)", lw=1, ls="--")
            ax.set_ylabel(label)
            ax.set_title(f"leg {leg} {stroke}: {label.split(' ')[0]}")
            if row == 2:
                ax.set_xlabel("time [s]")
            if row == 0:
                ax.legend(fontsize=7)
            ax2 = axes[row][2 * col + 1]
            ax2.plot([m * scale for m in meas], [m * scale for m in model], ",", alpha=0.3)
            lo = min(min(meas), min(model)) * scale
            hi = max(max(meas), max(model)) * scale
            ax2.plot([lo, hi], [lo, hi], "k-", lw=0.5)
            ax2.set_xlabel("measured")
            ax2.set_ylabel("model")
            ax2.set_title(f"{stroke}: {label.split(' ')[0]}, all samples")
    fig.tight_layout()
    fig.savefig(os.path.join(out_dir, f"predictions_leg{leg}.png"), dpi=90)
    plt.close(fig)


def plot_ga(out_dir):
    path = os.path.join(out_dir, "ga_history.csv")
    if not os.path.exists(path):
        return
    series = {}
    with open(path) as f:
        for r in csv.DictReader(f):
            series.setdefault((r["leg"], r["stroke"]), []).append(float(r["best_z"]))
    if not series:
        return
    fig, ax = plt.subplots(figsize=(8, 5))
    for (leg, stroke), z in sorted(series.items()):
        ax.semilogy(z, label=f"leg {leg} {stroke}", lw=1, ls="-" if stroke == "extend" else "--")
    ax.set_xlabel("GA iteration (Table 7 settings)")
    ax.set_ylabel("best Z (eq 13)")
    ax.legend(fontsize=7, ncol=2)
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(os.path.join(out_dir, "ga_convergence.png"), dpi=90)
    plt.close(fig)


def plot_errors(out_dir, result):
    strokes = [s for s in result["strokes"] if "truth" in s]
    if not strokes:
        return
    fig, axes = plt.subplots(1, 2, figsize=(13, 4.5), sharey=True)
    for ax, method in zip(axes, ("ga", "lsq")):
        for k, name in enumerate(NAMES):
            for s in strokes:
                if method not in s:
                    continue
                ok = s[f"{method}_curvature"]["identifiable"][k]
                truth = s["truth"][name]
                err = 100.0 * (s[method][name] - truth) / abs(truth) if truth else 0.0
                ax.plot(k + (0.15 if s["stroke"] == "retract" else -0.15), err if ok else 0.0,
                        "o" if ok else "x", color=f"C{s['leg'] - 1}", ms=4)
        ax.axhspan(-5, 5, color="green", alpha=0.08)
        ax.set_xticks(range(len(NAMES)))
        ax.set_xticklabels(NAMES)
        ax.set_title(f"{'GA (Table 7)' if method == 'ga' else 'least squares (Ceres)'}: identified - true, % "
                     "(x = not identifiable)")
        ax.grid(True, alpha=0.3)
    axes[0].set_ylabel("error %  (o extend left, retract right; colour = leg)")
    fig.tight_layout()
    fig.savefig(os.path.join(out_dir, "parameter_errors.png"), dpi=90)
    plt.close(fig)


def main():
    if len(sys.argv) != 2:
        print(__doc__)
        return 2
    out_dir = sys.argv[1]
    with open(os.path.join(out_dir, "identification.json")) as f:
        result = json.load(f)
    for leg in sorted({s["leg"] for s in result["strokes"]}):
        plot_predictions(out_dir, leg)
    plot_ga(out_dir)
    plot_errors(out_dir, result)
    print(f"plots written to {out_dir}: " + ", ".join(sorted(os.path.basename(p) for p in glob.glob(os.path.join(out_dir, "*.png")))))
    return 0


if __name__ == "__main__":
    sys.exit(main())
