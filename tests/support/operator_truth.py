#!/usr/bin/env python3
"""Ground truth of an operator session driven by hexa_operator or a Foxglove client
(tests/task_space/run_operator_modes_session.sh, tests/foxglove/run_operator_test.sh): reads the
session's supervisor.log (when the first jog started, its last message, when it was at rest; the
first goal, its start and its rest) and pose.csv (time, desired, true, measured), and checks
that the first jog (+x, work frame, at V m/s) moved the platform along +x and, let go, was at
rest within the dead-man time plus the braking time, the setpoint within the braking distance
and the platform (ground truth) within it + 4 mm; and that the first goal was reached: the
platform's move within the estimate's static offset + 4 mm of the one asked (the move is measured
from the truth at the goal's start, which stood that offset from the setpoint), at rest on it
within the static offset + 4 mm, 8 mrad. With PIVOT (x,y,z in the platform frame, m): the first
jog after the supervisor took that pivot ("frames set") is a rotation about it: the pivot point
(ground truth) stays within 5 mm of where it was while the platform rolls more than 0.15 rad and
its origin moves. Prints every figure; exit 1 if a check fails.
Usage: operator_truth.py OUT_DIR V_M_S [PIVOT]
"""
import csv
import math
import re
import sys

out = sys.argv[1]
v = float(sys.argv[2])  # the first jog's speed along +x, m/s
# The jog's limits (JogProfileConfig defaults, docs/operate.md "Jog"): A, J, the dead-man T_d.
A, J, TD = 0.25, 2.5, 0.25
STOP_S = TD + v / A + A / J                  # at rest this long after the last message at most
TRAVEL_M = v * TD + v * (v / A + A / J) / 2  # and this far along
log = open(out + "/supervisor.log").read()
rows = [list(map(float, r)) for r in list(csv.reader(open(out + "/pose.csv")))[1:]]
def at(ts, col):  # the row at or after time ts
    for r in rows:
        if r[0] >= ts - 1e-9: return r[col:col + 6]
    return rows[-1][col:col + 6]
DES, TRUE = 1, 7
ok = True
def expect(cond, what):
    global ok
    print(("ok: " if cond else "FAIL: ") + what)
    ok = ok and cond
m = re.search(r"jog at rest at t = ([0-9.]+) s, ([0-9.]+) s after the last jog message \(t = ([0-9.]+) s\)", log)
rest_t, after_s, last_t = float(m.group(1)), float(m.group(2)), float(m.group(3))
starts = [float(x) for x in re.findall(r"jogging from t = ([0-9.]+) s", log)]
t0 = starts[0]
# The platform 0.3 s after the setpoint came to rest, unless the next jog started before.
t_end = min(rest_t + 0.3, starts[1] - 0.005) if len(starts) > 1 else rest_t + 0.3
p0, p_last, p_rest = at(t0, TRUE), at(last_t, TRUE), at(t_end, TRUE)
d_last, d_rest = at(last_t, DES), at(rest_t, DES)
moved = [p_rest[k] - p0[k] for k in range(3)]
# The platform (ground truth) at rest: from when its x stays within 0.5 mm of where it ends.
truth_rest_t = last_t
for r in rows:
    if last_t <= r[0] <= t_end and abs(r[TRUE] - p_rest[0]) > 0.0005:
        truth_rest_t = r[0]
print(f"jog +x at {v} m/s: from t = {t0:.3f} s, last message t = {last_t:.3f} s, setpoint at rest "
      f"{after_s:.3f} s later (bound T_d + v/A + A/J = {STOP_S:.3f} s + one 5 ms tick); platform (truth) within "
      f"0.5 mm of its rest {truth_rest_t - last_t:.3f} s after the last message; truth at t = {t_end:.3f} s moved "
      f"({moved[0]*1e3:.2f}, {moved[1]*1e3:.2f}, {moved[2]*1e3:.2f}) mm; after the last message setpoint "
      f"{1e3*(d_rest[0]-d_last[0]):.2f} mm, truth {1e3*(p_rest[0]-p_last[0]):.2f} mm "
      f"(bound v T_d + v (v/A + A/J) / 2 = {TRAVEL_M*1e3:.2f} mm)")
expect(after_s <= STOP_S + 0.005 + 1e-9, "the jog was at rest within the dead-man time plus braking")
expect(moved[0] > 0.01 and math.hypot(moved[1], moved[2]) < 0.15 * moved[0], "the jog moved the platform along +x")
expect(d_last[0] < 0.1 - TRAVEL_M, "let go before the box limit (what stopped it is the braking)")
expect(d_rest[0] - d_last[0] <= TRAVEL_M + 1e-6, "setpoint travel after the last message within the braking bound")
expect(p_rest[0] - p_last[0] <= TRAVEL_M + 0.004, "truth travel after the last message within the bound + 4 mm")
# Goal: the platform's move within the estimator's static offset from the truth (measured at the
# goal's start, where the move is measured from) + 4 mm of the one asked, and at rest on the goal
# within that offset + 4 mm, 8 mrad.
g = re.search(r"goal #[0-9]+: \(([-0-9.]+), ([-0-9.]+), ([-0-9.]+)\) m, \(([-0-9.]+), ([-0-9.]+), ([-0-9.]+)\) rad", log)
goal = [float(g.group(k)) for k in range(1, 7)]
tg0 = float(re.search(r"goal started at t = ([0-9.]+) s", log).group(1))
tg = float(re.search(r"goal motion at rest at t = ([0-9.]+) s", log).group(1))
true0, des0 = at(tg0, TRUE), at(tg0, DES)
true_g, des_g = at(tg + 0.5, TRUE), at(tg, DES)
offset = math.dist(true0[:3], des0[:3])
asked = [goal[k] - des0[k] for k in range(3)]
moved = [true_g[k] - true0[k] for k in range(3)]
err_move = math.dist(asked, moved)
err_p = math.dist(true_g[:3], goal[:3]); err_r = max(abs(true_g[k] - goal[k]) for k in range(3, 6))
print(f"goal: planned from t = {tg0:.3f} s, at rest t = {tg:.3f} s; setpoint {1e3*math.dist(des_g[:3], goal[:3]):.4f} mm "
      f"from it; platform 0.5 s later {err_p*1e3:.2f} mm, {err_r*1e3:.2f} mrad from it (static offset of "
      f"the estimate from the truth before: {offset*1e3:.2f} mm); move {1e3*math.hypot(*asked):.2f} mm asked, "
      f"{err_move*1e3:.2f} mm off")
expect(math.dist(des_g[:3], goal[:3]) < 1e-4, "the setpoint ended on the goal (to the log's 0.1 mm)")
expect(err_move < offset + 0.004, "the platform's move within the static offset + 4 mm of the one asked")
expect(err_p < offset + 0.004 and err_r < 0.008, "the platform at rest on the goal within the static offset + 4 mm, 8 mrad")

def rotation(roll, pitch, yaw):  # R = Rz(yaw) Ry(pitch) Rx(roll) (core/pose.hpp)
    cr, sr, cp, sp, cy, sy = (math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch),
                              math.cos(yaw), math.sin(yaw))
    return [[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr]]

def pivot_in_base(q, p_PC_P):  # p + R p_PC_P for q = [x y z roll pitch yaw]
    R = rotation(*q[3:6])
    return [q[i] + sum(R[i][k] * p_PC_P[k] for k in range(3)) for i in range(3)]

if len(sys.argv) > 3:
    # Rotation about a pivot set at run time (docs/operate.md "Pivot point and user frames"): from
    # the first jog after "frames set" to 0.3 s after it was at rest (or the next motion's start).
    # 5 mm: the platform's tracking error of a jog (<= 3 mm) plus its roll error (< 8 mrad) over
    # the 0.2 m lever, as the in-process test (SupervisorLimits.RotationAboutAPivot...).
    p_PC_P = [float(x) for x in sys.argv[3].split(",")]
    t_frames = float(re.search(r"frames set at t = ([0-9.]+) s", log).group(1))
    t0 = min(t for t in (float(x) for x in re.findall(r"jogging from t = ([0-9.]+) s", log)) if t >= t_frames)
    rest_t = min(t for t in (float(x) for x in re.findall(r"jog at rest at t = ([0-9.]+) s", log)) if t > t0)
    d_rest = at(rest_t, DES)
    t_end = rest_t + 0.3
    for r in rows:  # the next motion (a trajectory's blend) starts where the setpoint leaves rest
        if rest_t < r[0] < t_end and max(abs(r[DES + k] - d_rest[k]) for k in range(6)) > 1e-7:
            t_end = r[0] - 0.005
            break
    span = [r for r in rows if t0 - 1e-9 <= r[0] <= t_end]
    true0, des0 = span[0][TRUE:TRUE + 6], span[0][DES:DES + 6]
    c_true0, c_des0 = pivot_in_base(true0, p_PC_P), pivot_in_base(des0, p_PC_P)
    pivot_true = max(math.dist(pivot_in_base(r[TRUE:TRUE + 6], p_PC_P), c_true0) for r in span)
    pivot_des = max(math.dist(pivot_in_base(r[DES:DES + 6], p_PC_P), c_des0) for r in span)
    origin_true = max(math.dist(r[TRUE:TRUE + 3], true0[:3]) for r in span)
    roll = span[-1][TRUE + 3] - true0[3]
    lever = math.hypot(*p_PC_P)
    print(f"pivot ({sys.argv[3]}) m, {lever:.3f} m from the platform origin, taken at t = {t_frames:.3f} s; "
          f"roll jog from t = {t0:.3f} s, at rest t = {rest_t:.3f} s, measured to t = {t_end:.3f} s: "
          f"roll {roll:.4f} rad (ground truth); the pivot point moved at most {pivot_true * 1e3:.2f} mm "
          f"(truth), {pivot_des * 1e3:.4f} mm (setpoint); the platform origin "
          f"moved {origin_true * 1e3:.2f} mm (truth)")
    expect(abs(roll) > 0.15, "the platform rolled more than 0.15 rad about the pivot")
    expect(pivot_des < 1e-6, "the setpoint's pivot point stayed put (pose.csv holds 9 digits)")
    expect(pivot_true < 0.005, "the pivot point (ground truth) stayed within 5 mm")
    expect(origin_true > 0.5 * lever * abs(roll), "the platform origin moved (about the old pivot, the origin)")
sys.exit(0 if ok else 1)
