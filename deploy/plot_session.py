#!/usr/bin/python3
"""Plots of a session, of the kinds in the paper (Figs 8-30), from the files that
`hexa_recorder report` writes into the output directory (docs/recorder.md, "CLI"):

  pose.csv    time_s, desired_/true_/measured_{x,y,z [m], roll,pitch,yaw [rad]}
  legs.csv    time_s, desired_length_m_N, measured_length_m_N [m], valve_v_N [V],
              friction_scale_N [1] (N = leg 1..6)
  events.csv  time_s, kind (state / fault / takeover / operator), leg, label
  report.json RMSE per axis, leg-length RMSE, session facts (meta)

Every time plot shades the supervisor's tracking window (the RMSE's window) and marks what
happened: faults (red), HOLD (purple), hot-standby take-overs (blue), operator commands
(grey), and the injected fault of --fault / --plant-fault (orange, dotted). Errors are in
mm and deg. Files written:

  summary.png        one page: session facts, RMSE table, events, errors, path
  pose_tracking.png  desired, ground truth, measured per axis, RMSE in each title
  pose_error.png     desired - ground truth, desired - measured, measured - ground truth
  leg_lengths.png    desired vs measured leg length, RMSE per leg
  valve_voltages.png per leg: the whole session (min/max per 20 ms or wider + mean), a 0.3 s zoom,
                     a histogram over the tracking window
  path_3d.png        3-D path with its three projections
  plots.json         what each PNG marks (the same JSON is in each PNG's "Description")

Usage: /usr/bin/python3 plot_session.py OUTPUT_DIR [--title TEXT]
Run with Debian's /usr/bin/python3 (python3-numpy, python3-matplotlib)."""
import argparse
import csv
import json
import os
import re
import sys
import textwrap
import time

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

AXES = ["x", "y", "z", "roll", "pitch", "yaw"]
MARK_STYLE = {  # kind: colour, line style, legend text
    "fault": ("tab:red", "-", "fault detected"),
    "hold": ("tab:purple", "--", "supervisor HOLD"),
    "takeover": ("tab:blue", "-.", "standby takes over"),
    "operator": ("0.4", ":", "operator command"),
    "injected": ("tab:orange", ":", "fault injected"),
}
TRACKING_COLOUR = "#d8f0d8"


class Progress:
    """One line per figure on a terminal (rewritten in place), plain lines in a log."""

    def __init__(self, total):
        self.total, self.done, self.t0 = total, 0, time.monotonic()
        self.tty = sys.stdout.isatty()

    def step(self, what):
        self.done += 1
        line = "plot_session: [%d/%d] %s (%.1f s)" % (self.done, self.total, what,
                                                      time.monotonic() - self.t0)
        if self.tty:
            sys.stdout.write("\r\033[K" + line + ("\n" if self.done == self.total else ""))
        else:
            sys.stdout.write(line + "\n")
        sys.stdout.flush()


def load_csv(path):
    """Columns by name, the " [unit]" of each header cell removed."""
    if not os.path.exists(path):
        sys.exit(f"plot_session: missing {path}")
    with open(path, newline="") as f:
        header = next(csv.reader(f), [])
    names = [re.sub(r"\s*\[.*\]$", "", h) for h in header]
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    if data.shape[0] == 0:
        sys.exit(f"plot_session: {path} has no rows")
    return {n: data[:, i] for i, n in enumerate(names)}


def load_events(path):
    if not os.path.exists(path):
        return []
    with open(path, newline="") as f:
        reader = csv.reader(f)
        next(reader, None)
        return [{"time_s": float(r[0]), "kind": r[1], "leg": int(r[2]), "label": r[3]}
                for r in reader if len(r) >= 4]


def injected_faults(meta):
    """The faults the session injected, from the report's session facts."""
    out = []
    m = re.match(r"leg (\d) (\w+) at ([0-9.]+) s", meta.get("fault", ""))
    if m:
        out.append({"time_s": float(m.group(3)), "kind": "injected", "leg": int(m.group(1)),
                    "label": f"leg {m.group(1)} {m.group(2)} injected"})
    m = re.match(r"supervisor crash at ([0-9.]+) s", meta.get("fault", ""))
    if m:
        out.append({"time_s": float(m.group(1)), "kind": "injected", "leg": 0,
                    "label": "supervisor crash injected"})
    for spec in filter(None, re.split(r"[ ,]+", meta.get("plant_fault", ""))):
        parts = spec.split(":")
        if len(parts) == 3:
            try:
                out.append({"time_s": float(parts[2]), "kind": "injected", "leg": int(parts[1]),
                            "label": f"{parts[0]} leg {parts[1]} injected"})
            except ValueError:
                pass
    return out


class Session:
    def __init__(self, out_dir):
        self.out = out_dir
        self.pose = load_csv(os.path.join(out_dir, "pose.csv"))
        self.legs = load_csv(os.path.join(out_dir, "legs.csv"))
        self.events = load_events(os.path.join(out_dir, "events.csv"))
        path = os.path.join(out_dir, "report.json")
        self.report = json.load(open(path)) if os.path.exists(path) else {}
        self.meta = self.report.get("session", {})
        self.events += injected_faults(self.meta)
        # At one time the injection first, then what it caused.
        self.events.sort(key=lambda e: (e["time_s"], e["kind"] != "injected"))
        self.end_s = float(max(np.nanmax(self.pose["time_s"]), np.nanmax(self.legs["time_s"])))
        self.windows = self.tracking_windows()
        self.marks = self.mark_list()
        self.metadata = {}

    def tracking_windows(self):
        """[start, end] of every stretch in TRACKING (end: the next state change)."""
        out, start = [], None
        for e in (e for e in self.events if e["kind"] == "state"):
            if e["label"] == "TRACKING" and start is None:
                start = e["time_s"]
            elif e["label"] != "TRACKING" and start is not None:
                out.append([start, e["time_s"]])
                start = None
        if start is not None:
            out.append([start, self.end_s])
        return out

    def mark_list(self):
        marks = []
        for e in self.events:
            kind = "hold" if e["kind"] == "state" and e["label"] == "HOLD" else e["kind"]
            if kind in MARK_STYLE:
                marks.append(dict(e, kind=kind))
        return marks

    def rmse(self, key, axis):
        """In mm / deg; None when the session never tracked (no window, no RMSE)."""
        if not self.report.get("tracking_pose_samples"):
            return None
        v = self.report.get(key, {}).get(axis + ("_m" if axis in "xyz" else "_rad"))
        return None if v is None else v * (1000.0 if axis in "xyz" else 180.0 / np.pi)


def scale(axis):
    return (1000.0, "mm") if axis in ("x", "y", "z") else (180.0 / np.pi, "deg")


def decorate(ax, s, label_marks=False, leg=None):
    """Shades the tracking window(s) and draws the marks; returns what it drew."""
    for a, b in s.windows:
        ax.axvspan(a, b, color=TRACKING_COLOUR, zorder=0, lw=0)
    drawn = []
    for m in s.marks:
        colour, style, _ = MARK_STYLE[m["kind"]]
        strong = leg is None or m["leg"] in (0, leg)
        ax.axvline(m["time_s"], color=colour, ls=style, lw=1.4 if strong else 0.7,
                   alpha=1.0 if strong else 0.4, zorder=3)
        drawn.append({"time_s": m["time_s"], "kind": m["kind"], "leg": m["leg"], "label": m["label"]})
    if label_marks:
        # Marks closer than 3 % of the time axis share one label (a fault, its detection and
        # the HOLD lie milliseconds apart).
        groups = []
        for m in s.marks:
            if groups and m["time_s"] - groups[-1][0]["time_s"] < 0.03 * max(s.end_s, 1e-3):
                groups[-1].append(m)
            else:
                groups.append([m])
        for g in groups:
            ax.annotate("\n".join(group_labels(g)), (g[0]["time_s"], 1.0),
                        xycoords=("data", "axes fraction"), xytext=(3, -3),
                        textcoords="offset points", rotation=90, va="top", ha="left", fontsize=7,
                        color=MARK_STYLE[g[0]["kind"]][0], zorder=7,
                        bbox=dict(boxstyle="square,pad=0.1", fc="white", ec="none", alpha=0.7))
    return drawn


def group_labels(marks):
    """Labels of marks drawn together; faults of one reason on several legs as one line
    ("legs 1,2,6 SETPOINT_STALE")."""
    lines, by_reason = [], {}
    for m in marks:
        f = re.match(r"leg (\d) (\S+) \((.*)\)$", m["label"]) if m["kind"] == "fault" else None
        if not f:
            lines.append(m["label"])
            continue
        if f.group(2) not in by_reason:
            by_reason[f.group(2)] = []
            lines.append(f.group(2))  # placeholder, filled below
        if f.group(1) not in by_reason[f.group(2)]:
            by_reason[f.group(2)].append(f.group(1))
    out = []
    for line in lines:
        legs = by_reason.get(line)
        if legs is None:
            out.append(line)
        else:
            out.append(("legs " if len(legs) > 1 else "leg ") + ",".join(sorted(legs)) + " " + line)
    return out


def legend_handles(s):
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch
    handles = [Patch(color=TRACKING_COLOUR, label="tracking window (RMSE)")]
    for kind in sorted({m["kind"] for m in s.marks}):
        colour, style, text = MARK_STYLE[kind]
        handles.append(Line2D([], [], color=colour, ls=style, label=text))
    return handles


def save(fig, s, name, description):
    description = dict(description, figure=name, tracking_windows_s=s.windows)
    s.metadata[name] = description
    fig.savefig(os.path.join(s.out, name), dpi=100,
                metadata={"Title": name, "Description": json.dumps(description)})
    plt.close(fig)


def six_panels(title):
    fig, axs = plt.subplots(3, 2, figsize=(13, 10), sharex=True)
    fig.suptitle(title)
    for ax in axs.flat:
        ax.ticklabel_format(axis="y", useOffset=False)
    return fig, [axs[i % 3][i // 3] for i in range(6)], axs


def finish_panels(fig, s, axs, first, name, description):
    """Time axis labels, one legend for the figure (the first panel's lines and the marks),
    and the file with its plotting data."""
    for ax in axs[-1]:
        ax.set_xlabel("simulated time [s]")
    handles, _ = first.get_legend_handles_labels()
    fig.legend(handles=handles + legend_handles(s), loc="lower center", ncol=4, fontsize=8)
    fig.tight_layout(rect=(0, 0.05, 1, 1))
    save(fig, s, name, description)


def plot_tracking(s, title):
    fig, panels, axs = six_panels(f"{title}: desired, ground truth and measured pose "
                                  "(cf. paper Figs 8-13, 21-23)")
    t = s.pose["time_s"]
    marks, rmse = [], {}
    for i, axis in enumerate(AXES):
        ax = panels[i]
        k, unit = scale(axis)
        marks = decorate(ax, s, label_marks=i in (0, 3))
        ax.plot(t, k * s.pose[f"desired_{axis}"], "k--", lw=1.0, label="desired", zorder=4)
        # The measured pose (noisier) as a wide pale band, the ground truth thin and dark on
        # top: both stay visible where they overlap.
        ax.plot(t, k * s.pose[f"measured_{axis}"], color="tab:orange", lw=2.4, alpha=0.45,
                label="measured (GQFK + IMU)", zorder=5)
        ax.plot(t, k * s.pose[f"true_{axis}"], color="navy", lw=0.8,
                label="ground truth (plant)", zorder=6)
        r = s.rmse("rmse_vs_ground_truth", axis)
        rmse[axis] = r
        ax.set_title(f"{axis}: RMSE vs ground truth " + (f"{r:.2f} {unit}" if r is not None else "-"),
                     fontsize=9)
        ax.set_ylabel(f"{axis} [{unit}]")
        ax.grid(True, alpha=0.3)
    finish_panels(fig, s, axs, panels[0], "pose_tracking.png",
                  {"markers": marks, "rmse_vs_ground_truth": rmse, "units": {"x": "mm", "roll": "deg"}})


def plot_error(s, title):
    fig, panels, axs = six_panels(f"{title}: task-space error (mm, deg)")
    t = s.pose["time_s"]
    marks, rmse = [], {}
    for i, axis in enumerate(AXES):
        ax = panels[i]
        k, unit = scale(axis)
        marks = decorate(ax, s, label_marks=i in (0, 3))
        d, g, m = (s.pose[f"{w}_{axis}"] for w in ("desired", "true", "measured"))
        ax.plot(t, k * (d - g), color="tab:blue", lw=1.0, label="desired - ground truth")
        ax.plot(t, k * (d - m), color="tab:orange", lw=0.8, alpha=0.8, label="desired - measured")
        ax.plot(t, k * (m - g), color="tab:green", lw=0.7, alpha=0.8,
                label="measured - ground truth (estimator)")
        rt, rm = s.rmse("rmse_vs_ground_truth", axis), s.rmse("rmse_vs_measured_pose", axis)
        rmse[axis] = {"vs_ground_truth": rt, "vs_measured": rm}
        fmt = lambda v: "-" if v is None else f"{v:.2f}"  # noqa: E731
        ax.set_title(f"{axis}: RMSE vs truth {fmt(rt)} {unit}, vs measured {fmt(rm)} {unit}",
                     fontsize=9)
        ax.set_ylabel(f"error {axis} [{unit}]")
        ax.grid(True, alpha=0.3)
        clip_to_window(ax, s, t, [k * (d - g), k * (d - m)])
    finish_panels(fig, s, axs, panels[0], "pose_error.png",
                  {"markers": marks, "rmse": rmse, "units": {"x": "mm", "roll": "deg"}})


def clip_to_window(ax, s, t, series):
    """Y range from the tracking window (plus a margin), so that the start-up transient does
    not flatten the error that the RMSE measures; values outside are clipped by the axes."""
    if not s.windows:
        return
    inside = np.zeros_like(t, dtype=bool)
    for a, b in s.windows:
        inside |= (t >= a) & (t <= b)
    vals = np.concatenate([v[inside] for v in series])
    vals = vals[np.isfinite(vals)]
    if vals.size == 0:
        return
    lo, hi = float(vals.min()), float(vals.max())
    pad = 0.15 * (hi - lo) + 1e-6
    ax.set_ylim(lo - pad, hi + pad)


def plot_legs(s, title):
    fig, panels, axs = six_panels(f"{title}: desired vs measured leg lengths "
                                  "(cf. paper Figs 24-29)")
    t = s.legs["time_s"]
    marks, rmse = {}, {}
    rms = s.report.get("leg_length_rmse_m", [None] * 6)
    if not s.report.get("tracking_pose_samples"):
        rms = [None] * 6  # never tracked: no window, no RMSE
    for leg in range(1, 7):
        ax = panels[leg - 1]
        marks[leg] = decorate(ax, s, label_marks=leg in (1, 4), leg=leg)
        ax.plot(t, 1000 * s.legs[f"desired_length_m_{leg}"], "k--", lw=1.0, label="desired")
        ax.plot(t, 1000 * s.legs[f"measured_length_m_{leg}"], color="tab:blue", lw=1.0,
                label="measured (potentiometer)")
        r = rms[leg - 1]
        rmse[leg] = None if r is None else 1000 * r
        ax.set_title(f"leg {leg}: RMSE " + ("-" if r is None else f"{1000 * r:.2f} mm"), fontsize=9)
        ax.set_ylabel(f"leg {leg} length [mm]")
        ax.grid(True, alpha=0.3)
    finish_panels(fig, s, axs, panels[0], "leg_lengths.png",
                  {"markers": marks[1], "markers_per_leg": marks, "rmse_mm": rmse})


def envelope(t, v, bin_s):
    """min, mean, max of v per bin of bin_s seconds (NaN ignored)."""
    edges = np.floor((t - t[0]) / bin_s).astype(int)
    n = edges.max() + 1
    lo, hi = np.full(n, np.nan), np.full(n, np.nan)
    mean = np.full(n, np.nan)
    ok = np.isfinite(v)
    for name, fn, arr in (("min", np.fmin, lo), ("max", np.fmax, hi)):
        fn.at(arr, edges[ok], v[ok])
    sums = np.bincount(edges[ok], weights=v[ok], minlength=n)
    counts = np.bincount(edges[ok], minlength=n)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = sums / counts
    centres = t[0] + (np.arange(n) + 0.5) * bin_s
    return centres, lo, mean, hi


def zoom_window(s, length_s=0.3):
    """A short window where something happens: just before the first fault / take-over /
    HOLD, else in the middle of the tracking window."""
    for m in s.marks:
        if m["kind"] in ("fault", "takeover", "hold", "injected"):
            start = max(0.0, m["time_s"] - 0.5 * length_s)
            return [start, start + length_s]
    if s.windows:
        a, b = s.windows[0]
        mid = 0.5 * (a + b)
        return [mid - 0.5 * length_s, mid + 0.5 * length_s]
    return [0.5 * s.end_s - 0.5 * length_s, 0.5 * s.end_s + 0.5 * length_s]


def plot_valves(s, title):
    fig, axs = plt.subplots(6, 3, figsize=(15, 15), gridspec_kw={"width_ratios": [3, 2, 1]})
    t = s.legs["time_s"]
    zoom = zoom_window(s)
    inside = np.zeros_like(t, dtype=bool)
    for a, b in s.windows:
        inside |= (t >= a) & (t <= b)
    marks = {}
    # 20 ms bins, wider for a long session (at most ~1500 bins across the panel).
    bin_s = max(0.02, float(np.nanmax(t) - np.nanmin(t)) / 1500)
    steps = s.report.get("valve_mean_abs_step_v_per_tick", [None] * 6)
    sat = s.report.get("valve_saturated_fraction", [None] * 6)
    for leg in range(1, 7):
        v = s.legs[f"valve_v_{leg}"]
        whole, near, hist = axs[leg - 1]
        marks[leg] = decorate(whole, s, label_marks=leg == 1, leg=leg)
        c, lo, mean, hi = envelope(t, v, bin_s)
        whole.fill_between(c, lo, hi, color="0.45", alpha=0.35, lw=0, label=f"min-max per {1000 * bin_s:.0f} ms")
        whole.plot(c, mean, color="k", lw=0.8, label=f"mean per {1000 * bin_s:.0f} ms")
        whole.axvspan(zoom[0], zoom[1], color="k", alpha=0.12, lw=0)
        whole.axhline(5.0, color="k", lw=0.6, ls=":")
        whole.set_ylim(-0.3, 10.3)
        step = steps[leg - 1]
        frac = sat[leg - 1]
        info = ""
        if step is not None and frac is not None:
            info = f": mean |step| {step:.3f} V/tick, saturated {100 * frac:.2f} %"
        whole.set_title(f"leg {leg}{info}", fontsize=9)
        whole.set_ylabel(f"leg {leg} valve [V]")
        sel = (t >= zoom[0]) & (t <= zoom[1])
        decorate(near, s, leg=leg)
        near.plot(t[sel], v[sel], color="k", lw=0.8, marker=".", ms=2)
        near.axhline(5.0, color="k", lw=0.6, ls=":")
        near.set_xlim(zoom)
        near.set_title(f"zoom {zoom[0]:.2f}-{zoom[1]:.2f} s (every 1 ms tick)", fontsize=9)
        vals = v[inside & np.isfinite(v)] if inside.any() else v[np.isfinite(v)]
        hist.hist(vals, bins=50, range=(0, 10), color="0.35", orientation="horizontal")
        hist.set_xscale("log")
        hist.set_ylim(-0.3, 10.3)
        hist.set_title("histogram (tracking window)", fontsize=9)
        for ax in (whole, near, hist):
            ax.grid(True, alpha=0.3)
    axs[-1][0].set_xlabel("simulated time [s]")
    axs[-1][1].set_xlabel("simulated time [s]")
    axs[-1][2].set_xlabel("ticks")
    handles, _ = axs[0][0].get_legend_handles_labels()
    fig.legend(handles=handles + legend_handles(s), loc="lower center", ncol=5, fontsize=8)
    fig.suptitle(f"{title}: valve commands the plant applied, closed (null) at 5 V "
                 "(cf. paper Figs 14-19, 30)")
    fig.tight_layout(rect=(0, 0.03, 1, 0.985))
    save(fig, s, "valve_voltages.png", {"markers": marks[1], "markers_per_leg": marks,
                                        "zoom_s": zoom})


def plot_path(s, title):
    fig = plt.figure(figsize=(12, 10))
    p = {w: [1000 * s.pose[f"{w}_{a}"] for a in "xyz"] for w in ("desired", "true")}
    ax = fig.add_subplot(2, 2, 1, projection="3d")
    ax.plot(*p["desired"], "k--", lw=1.0, label="desired")
    ax.plot(*p["true"], color="tab:blue", lw=1.2, label="ground truth")
    # Shadows on the floor and back walls give the 3-D line its depth.
    lims = [(np.nanmin(np.r_[p["desired"][i], p["true"][i]]),
             np.nanmax(np.r_[p["desired"][i], p["true"][i]])) for i in range(3)]
    x, y, z = p["true"]
    ax.plot(x, y, np.full_like(z, lims[2][0]), color="0.6", lw=0.6)
    ax.plot(x, np.full_like(y, lims[1][1]), z, color="0.6", lw=0.6)
    ax.plot(np.full_like(x, lims[0][0]), y, z, color="0.6", lw=0.6)
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.set_zlabel("z [mm]")
    ax.set_title("3-D (grey: shadows on the walls)", fontsize=9)
    for k, (i, j) in enumerate(((0, 1), (0, 2), (1, 2))):
        a = fig.add_subplot(2, 2, k + 2)
        a.plot(p["desired"][i], p["desired"][j], "k--", lw=1.0, label="desired")
        a.plot(p["true"][i], p["true"][j], color="tab:blue", lw=1.0, label="ground truth")
        a.set_xlabel("xyz"[i] + " [mm]")
        a.set_ylabel("xyz"[j] + " [mm]")
        a.set_title(f"{'xyz'[i]}-{'xyz'[j]} projection", fontsize=9)
        a.set_aspect("equal", adjustable="datalim")
        a.grid(True, alpha=0.3)
    ax.legend(loc="upper left", fontsize=8)
    fig.suptitle(f"{title}: path of the platform origin (cf. paper Fig. 20)")
    fig.tight_layout()
    save(fig, s, "path_3d.png", {"markers": [], "units": "mm"})


def plot_summary(s, title):
    fig = plt.figure(figsize=(13, 10))
    gs = fig.add_gridspec(3, 2, height_ratios=[0.75, 1, 1])
    text = fig.add_subplot(gs[0, :])
    text.axis("off")
    meta = s.meta
    facts = ", ".join(f"{k} {meta[k]}" for k in ("trajectory", "controller", "profile", "mode",
                                                 "seed", "completed") if k in meta)
    extra = [f"{k}: {meta[k]}" for k in ("fault", "plant_fault", "rig_overlays") if k in meta]
    lines = [facts] + extra
    lines.append("simulated %.2f s, wall %.2f s, final supervisor state %s" % (
        s.report.get("sim_time_s") or 0, s.report.get("wall_time_s") or 0,
        s.report.get("final_supervisor_state", "?")))
    if s.windows:
        lines.append("tracking window " + ", ".join(f"{a:.2f}-{b:.2f} s" for a, b in s.windows))
    else:
        lines.append("never tracked: no tracking window, no RMSE")
    # Wrapped so that the facts never run into the events column at 0.65 of the width.
    wrapped = [w for line in lines for w in textwrap.wrap(line, 80, subsequent_indent="  ")]
    text.text(0, 1, "\n".join(wrapped), va="top", fontsize=9, family="monospace")
    header = ["", "x mm", "y mm", "z mm", "roll deg", "pitch deg", "yaw deg"]
    cells = []
    for key, name in (("rmse_vs_ground_truth", "RMSE vs ground truth"),
                      ("rmse_vs_measured_pose", "RMSE vs measured")):
        row = [name]
        for a in AXES:
            v = s.rmse(key, a)
            row.append("-" if v is None else f"{v:.2f}")
        cells.append(row)
    table = text.table(cellText=cells, colLabels=header, loc="center", bbox=(0, 0.0, 0.62, 0.45))
    table.auto_set_font_size(False)
    table.set_fontsize(8)
    shown = [m for m in s.marks][:10]
    ev = "\n".join(f"{m['time_s']:7.3f} s  {m['label']}" for m in shown) or "no faults, HOLD, " \
        "take-overs or operator commands"
    if len(s.marks) > len(shown):
        ev += f"\n... {len(s.marks) - len(shown)} more in events.csv"
    text.text(0.65, 1.0, "events:\n" + ev, va="top", fontsize=8, family="monospace")
    t = s.pose["time_s"]
    marks = []
    for col, axes_, unit, k in ((0, "xyz", "mm", 1000.0), (1, ("roll", "pitch", "yaw"), "deg",
                                                           180.0 / np.pi)):
        ax = fig.add_subplot(gs[1, col])
        marks = decorate(ax, s, label_marks=True)
        for a in axes_:
            ax.plot(t, k * (s.pose[f"desired_{a}"] - s.pose[f"true_{a}"]), lw=0.9,
                    label=f"{a}")
        clip_to_window(ax, s, t, [k * (s.pose[f"desired_{a}"] - s.pose[f"true_{a}"]) for a in axes_])
        ax.set_ylabel(f"desired - ground truth [{unit}]")
        ax.set_xlabel("simulated time [s]")
        ax.legend(fontsize=8, loc="lower left")
        ax.grid(True, alpha=0.3)
    ax = fig.add_subplot(gs[2, 0])
    decorate(ax, s)
    legs_t = s.legs["time_s"]
    for leg in range(1, 7):
        e = 1000 * (s.legs[f"desired_length_m_{leg}"] - s.legs[f"measured_length_m_{leg}"])
        ax.plot(legs_t, e, lw=0.7, label=f"leg {leg}")
    clip_to_window(ax, s, legs_t, [1000 * (s.legs[f"desired_length_m_{leg}"] -
                                          s.legs[f"measured_length_m_{leg}"]) for leg in range(1, 7)])
    ax.ticklabel_format(axis="y", useOffset=False)
    ax.set_ylabel("leg length error (desired - measured) [mm]")
    ax.set_xlabel("simulated time [s]")
    ax.legend(fontsize=7, ncol=3, loc="lower left")
    ax.grid(True, alpha=0.3)
    ax = fig.add_subplot(gs[2, 1])
    ax.plot(1000 * s.pose["desired_x"], 1000 * s.pose["desired_y"], "k--", lw=1.0, label="desired")
    ax.plot(1000 * s.pose["true_x"], 1000 * s.pose["true_y"], color="tab:blue", lw=1.0,
            label="ground truth")
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.legend(fontsize=8)
    ax.grid(True, alpha=0.3)
    ax.set_title("x-y path", fontsize=9)
    fig.legend(handles=legend_handles(s), loc="lower center", ncol=6, fontsize=8)
    fig.suptitle(f"{title}: session summary")
    fig.tight_layout(rect=(0, 0.03, 1, 1))
    save(fig, s, "summary.png", {"markers": marks, "events_listed": len(shown)})


def main():
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("out_dir")
    parser.add_argument("--title", default="session")
    args = parser.parse_args()
    s = Session(args.out_dir)
    steps = [("summary.png", plot_summary), ("pose_tracking.png", plot_tracking),
             ("pose_error.png", plot_error), ("leg_lengths.png", plot_legs),
             ("valve_voltages.png", plot_valves), ("path_3d.png", plot_path)]
    progress = Progress(len(steps))
    for name, fn in steps:
        fn(s, args.title)
        progress.step(name)
    with open(os.path.join(args.out_dir, "plots.json"), "w") as f:
        json.dump(s.metadata, f, indent=1)
    print("plot_session: wrote " + " ".join(n for n, _ in steps) + " plots.json")


if __name__ == "__main__":
    main()
