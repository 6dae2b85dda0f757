#!/usr/bin/python3
"""Rendered check of the 3-D scene (docs/foxglove.md): draws scene frames extracted from a
recording (js/extract_frames.mjs) with matplotlib the way a viewer places them - leg cylinders
from their pose and size, base joints in `base`, platform joints moved by the base->platform
transform - and compares every leg with the recording's ground truth:
  * the leg length from the drawn cylinder's end points, and from the drawn joints, equals the
    GroundTruth leg_length_m of the same tick within --tolerance-mm (default 1 mm);
  * the cylinder's ends touch the drawn joints (within the same tolerance).
Writes the first frame as PNG. Exit 0 when every check passes, 1 otherwise.
  /usr/bin/python3 render_scene.py FRAMES.json OUT.png [--tolerance-mm 1]
"""
import faulthandler
import json
import sys

# A hang (one CI run timed out here with no output) prints every thread's stack and exits.
faulthandler.dump_traceback_later(100, exit=True)

import numpy as np  # noqa: E402
import matplotlib  # noqa: E402

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def rot(q):
    x, y, z, w = q["x"], q["y"], q["z"], q["w"]
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


def vec(p):
    return np.array([p["x"], p["y"], p["z"]])


def main():
    if len(sys.argv) < 3:
        print(__doc__)
        return 2
    frames_path, png = sys.argv[1], sys.argv[2]
    tol_mm = 1.0
    if "--tolerance-mm" in sys.argv:
        tol_mm = float(sys.argv[sys.argv.index("--tolerance-mm") + 1])
    data = json.load(open(frames_path))
    failures = 0
    worst_mm = 0.0
    checked = 0
    for k, f in enumerate(data["frames"]):
        if f["truth"] is None:
            print(f"FAIL: frame at tick {f['tick']}: no GroundTruth of that tick in the recording")
            failures += 1
            continue
        R_tf = rot(f["platform_tf"]["q"])
        t_tf = vec(f["platform_tf"]["t"])
        base_joints = [vec(p) for p in f["base_joints"]]
        plat_joints = [t_tf + R_tf @ vec(p) for p in f["platform_joints_P"]]
        ends = []
        for i, leg in enumerate(f["legs"]):
            axis = rot(leg["q"]) @ np.array([0.0, 0.0, 1.0])
            c = vec(leg["center"])
            a, b = c - 0.5 * leg["height"] * axis, c + 0.5 * leg["height"] * axis
            ends.append((a, b))
            truth_m = f["truth"]["leg_length_m"][i]
            drawn_m = float(np.linalg.norm(b - a))
            joints_m = float(np.linalg.norm(plat_joints[i] - base_joints[i]))
            touch_mm = 1e3 * max(float(np.linalg.norm(a - base_joints[i])),
                                 float(np.linalg.norm(b - plat_joints[i])))
            err_mm = 1e3 * max(abs(drawn_m - truth_m), abs(joints_m - truth_m))
            worst_mm = max(worst_mm, err_mm, touch_mm)
            checked += 1
            if err_mm > tol_mm or touch_mm > tol_mm:
                failures += 1
                print(f"FAIL: tick {f['tick']} leg {i + 1}: drawn {drawn_m:.6f} m, joints "
                      f"{joints_m:.6f} m, truth {truth_m:.6f} m (|error| {err_mm:.3f} mm), "
                      f"ends off the joints by {touch_mm:.3f} mm")
        if k == 0:
            fig = plt.figure(figsize=(7, 6))
            ax = fig.add_subplot(projection="3d")
            for loop, color in ((base_joints, "0.4"), (plat_joints, "tab:blue")):
                pts = np.array(loop)
                order = np.argsort(np.arctan2(pts[:, 1] - pts[:, 1].mean(), pts[:, 0] - pts[:, 0].mean()))
                pts = pts[np.append(order, order[0])]
                ax.plot(pts[:, 0], pts[:, 1], pts[:, 2], color=color)
                ax.scatter(pts[:, 0], pts[:, 1], pts[:, 2], color=color, s=20)
            for i, (a, b) in enumerate(ends):
                ax.plot([a[0], b[0]], [a[1], b[1]], [a[2], b[2]], linewidth=4,
                        label=f"leg {i + 1} ({f['legs'][i]['state']}) "
                              f"{1e3 * np.linalg.norm(b - a):.2f} mm, truth "
                              f"{1e3 * f['truth']['leg_length_m'][i]:.2f} mm")
            ax.set_xlabel("x [m]")
            ax.set_ylabel("y [m]")
            ax.set_zlabel("z [m]")
            ax.set_title(f"scene frame at tick {f['tick']} (hexa_Scene)")
            ax.legend(fontsize=7, loc="upper left")
            fig.savefig(png, dpi=90)
            plt.close(fig)
    print(f"{checked} legs in {len(data['frames'])} frames checked against GroundTruth "
          f"(joints: {data['frames'][0]['joints_note'] if data['frames'] else '-'}); largest "
          f"deviation {worst_mm:.6f} mm, tolerance {tol_mm} mm; {failures} failures; drawing {png}")
    return 0 if failures == 0 and checked > 0 else 1


if __name__ == "__main__":
    sys.exit(main())
