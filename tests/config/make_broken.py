#!/usr/bin/env python3
"""Writes tests/config/broken/*.textproto: each a copy of deploy/rigs/hexataar_r.textproto
with ONE defect. The line that the loader must report carries the comment `# DEFECT`
(for a block removed from the top level: the last line of the file); the test finds the
expected line from that marker, independently of the loader.

Rerun after changing the reference file:  /usr/bin/python3 tests/config/make_broken.py
`--check` writes nothing and exits 1 if a stored file differs from what would be written
(ctest runs it, so a reference edit without regenerating is caught).
"""
import math
import pathlib
import re
import sys

HERE = pathlib.Path(__file__).resolve().parent
ROOT = HERE.parent.parent
REFERENCE = (ROOT / "deploy/rigs/hexataar_r.textproto").read_text().splitlines()


def fmt(v):
    s = ("%.12f" % v).rstrip("0").rstrip(".")
    return "0" if s in ("-0", "") else s


def find(lines, pattern, occurrence=0):
    hits = [i for i, l in enumerate(lines) if re.search(pattern, l)]
    return hits[occurrence]


def replace(pattern, new_text, note, occurrence=0):
    """Replace the value after `pattern` on its (occurrence-th) line and mark that line."""
    def edit(lines):
        i = find(lines, pattern, occurrence)
        indent = re.match(r"\s*", lines[i]).group(0)
        lines[i] = indent + new_text + "  # DEFECT: " + note
    return edit


def delete_line(pattern, block_pattern, note):
    """Delete a field; the expected line is the start of its block."""
    def edit(lines):
        i = find(lines, pattern)
        del lines[i]
        j = max(k for k in range(i) if re.search(block_pattern, lines[k]))
        lines[j] += "  # DEFECT: " + note
    return edit


def delete_block(block_start, note):
    """Delete a whole top-level block; the expected line is the end of the file."""
    def edit(lines):
        i = find(lines, block_start)
        j = next(k for k in range(i, len(lines)) if lines[k].startswith("}"))
        del lines[i:j + 1]
        lines.append("# DEFECT: " + note)
    return edit


def delete_block_lines(element_start, block, note):
    """Delete the first `element_start` { ... } element inside top-level `block`; mark the block."""
    def edit(lines):
        b = find(lines, r"^" + block + r" \{")
        i = next(k for k in range(b, len(lines)) if re.search(element_start, lines[k]))
        j = next(k for k in range(i, len(lines)) if lines[k].startswith("  }"))
        del lines[i:j + 1]
        lines[b] += "  # DEFECT: " + note
    return edit


def platform_joints(azimuths_deg, note):
    """Rewrite every platform joint at the given azimuths (0.25 m circle); mark geometry."""
    def edit(lines):
        for k, az in enumerate(azimuths_deg):
            i = find(lines, r"p_PB_P_m \{", k)
            a = math.radians(az)
            indent = re.match(r"\s*", lines[i]).group(0)
            lines[i] = (indent + "p_PB_P_m { x: %s y: %s z: 0 }" %
                        (fmt(0.25 * math.cos(a)), fmt(0.25 * math.sin(a))))
        lines[find(lines, r"^geometry \{")] += "  # DEFECT: " + note
    return edit


def base_joints_on_line(note):
    def edit(lines):
        for k in range(6):
            i = find(lines, r"p_BA_B_m \{", k)
            lines[i] = re.sub(r"x: [-0-9.e]+", "x: 0", lines[i])
        lines[find(lines, r"^geometry \{")] += "  # DEFECT: " + note
    return edit


CASES = {
    "syntax_error": replace(r"moving_mass_kg:", "moving_mass_kg 0.25", "colon missing"),
    "unknown_field": replace(r"cap_area_m2:", "cap_aera_m2: 3.1416e-4", "misspelt field name"),
    "missing_field": delete_line(r"rod_area_m2:", r"^cylinder \{", "rod_area_m2 removed"),
    "missing_block": delete_block(r"^valve \{", "valve block removed"),
    "negative_mass": replace(r"mass_kg: 6", "mass_kg: -6", "negative platform mass"),
    "zero_area": replace(r"cap_area_m2:", "cap_area_m2: 0", "non-positive area"),
    "annulus_ge_cap": replace(r"annulus_area_m2:", "annulus_area_m2: 3.5e-4", "annulus >= cap"),
    "valve_null_outside": replace(r"null_voltage_v:", "null_voltage_v: 12", "null above max"),
    "non_finite": replace(r"bristle_damping_n_s_m:", "bristle_damping_n_s_m: inf", "infinite value"),
    "coincident_joints": replace(r"p_BA_B_m \{", "p_BA_B_m { x: 0.344682713554 y: -0.060776862183 z: 0 }",
                                 "leg 2 base joint = leg 1 base joint", occurrence=1),
    "collinear_base": base_joints_on_line("all base joints on the y axis"),
    "singular_geometry": platform_joints([350, 10, 110, 130, 230, 250],
                                         "platform joints at the base joints' azimuths"),
    "ill_conditioned_geometry": platform_joints([349.5, 10.5, 109.5, 130.5, 229.5, 250.5],
                                                "platform joints 0.5 deg from the base azimuths"),
    "home_outside_stroke": replace(r"home_position_m \{", "home_position_m { x: 0 y: 0 z: 0.62 }",
                                   "home too high"),
    "window_too_small": replace(r"window:", "window: 1", "differentiator window < 2"),
    "sigma_zero": replace(r"sigma: 0.85", "sigma: 0", "differentiator sigma <= 0"),
    "unknown_profile": replace(r"^default_profile:", 'default_profile: "realsitic"', "misspelt profile"),
    "duplicate_profile": replace(r'name: "ideal"', 'name: "realistic"', "profile defined twice"),
    "duplicate_leg_id": replace(r"id: 6", "id: 5", "leg 5 twice"),
    # Physical limits (docs/config.md): each value passes the per-struct rules.
    "supply_beyond_ideal_gas": replace(r"supply_pressure_pa:", "supply_pressure_pa: 5e6",
                                       "50 bar: air is no longer an ideal gas"),
    "platform_too_heavy": replace(r"mass_kg: 6", "mass_kg: 1e30", "legs cannot hold it"),
    "spool_faster_than_step": replace(r"spool_time_constant_s:", "spool_time_constant_s: 1e-9",
                                      "spool lag shorter than the plant's step"),
    "lambda_beyond_valve_chain": replace(r"lambda_1_s:", "lambda_1_s: 1e12",
                                         "sliding surface faster than the valve chain"),
    "end_stop_too_stiff": replace(r"end_stop_stiffness_n_m:", "end_stop_stiffness_n_m: 1e9",
                                  "end stop stiffer than the plant's step resolves"),
    "heat_ratio_above_monatomic": replace(r"heat_ratio:", "heat_ratio: 1.8", "k above 5/3"),
    "feedback_rate_fraction_above_one": replace(r"feedback_rate_fraction:", "feedback_rate_fraction: 1.5",
                                                "more than the feedback part's whole rate in phi_dot"),
    "observer_mass_zero": replace(r"observer_mass_kg:", "observer_mass_kg: 0", "observer without mass"),
    "dither_too_fast": replace(r"dither_frequency_hz:", "dither_frequency_hz: 400",
                               "2.5 control periods per dither cycle"),
    # The remote I/O board's channel calibration (docs/board_protocol.md).
    "board_gain_zero": replace(r"valve_v \{", "valve_v { offset_si: 0 gain_si_per_count: 0 min_si: 0 max_si: 10 }",
                               "leg 3's valve channel has no gain", occurrence=2),
    "board_potentiometer_short": replace(
        r"potentiometer_m \{", "potentiometer_m { offset_si: 0.3734 gain_si_per_count: 4.0e-6 min_si: 0.40 max_si: 0.6324 }",
        "leg 1's potentiometer range misses the short end of the stroke"),
    "board_five_legs": delete_block_lines(r"^  leg \{", "board", "a board block with five legs"),
    # The supervisor's soft limits (docs/operate.md "Soft limits").
    "soft_box_excludes_home": replace(r"position_max_from_home_m \{",
                                      "position_max_from_home_m { x: 0.1 y: -0.02 z: 0.1 }",
                                      "the box's y maximum is below home"),
    "soft_box_beyond_workspace": replace(r"rotation_max_rad \{",
                                         "rotation_max_rad { roll: 0.3 pitch: 0.6 yaw: 0.3 }",
                                         "pitch bound beyond the workspace check"),
    "soft_joint_limit_zero": replace(r"max_platform_joint_angle_rad:", "max_platform_joint_angle_rad: 0",
                                     "no platform joint deflection allowed"),
}


def main():
    check = "--check" in sys.argv[1:]
    out_dir = HERE / "broken"
    out_dir.mkdir(exist_ok=True)
    stale = []
    for name, edit in CASES.items():
        lines = list(REFERENCE)
        lines[0:0] = ["# BROKEN COPY of deploy/rigs/hexataar_r.textproto (tests/config/make_broken.py): "
                      + name]
        edit(lines)
        assert sum("DEFECT" in l for l in lines) == 1, name
        text = "\n".join(lines) + "\n"
        path = out_dir / (name + ".textproto")
        if check:
            if not path.exists() or path.read_text() != text:
                stale.append(path.name)
        else:
            path.write_text(text)
    if check:
        if stale:
            print("stale broken files (rerun tests/config/make_broken.py): " + ", ".join(stale))
            return 1
        print("all %d broken files match the reference" % len(CASES))
        return 0
    print("wrote %d files to %s" % (len(CASES), out_dir))
    return 0


if __name__ == "__main__":
    sys.exit(main())
