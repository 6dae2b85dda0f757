#!/usr/bin/python3
"""Unit tests of studies/user_path_tables.py's tables: fixture report.json contents (the keys
hexa_recorder report writes), no session run."""
import os
import sys
import tempfile
import types
import unittest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "studies"))
import user_path_tables as upt  # noqa: E402

DEG = 57.29577951308232


def report(cm_deg, valve=(0.15, 0.005)):
    """A report.json with the given RMSE against ground truth (x y z cm, roll pitch yaw deg)."""
    keys = ["x_m", "y_m", "z_m", "roll_rad", "pitch_rad", "yaw_rad"]
    return {"tracking_pose_samples": 1000,
            "rmse_vs_ground_truth": {k: v / (100.0 if i < 3 else DEG)
                                     for i, (k, v) in enumerate(zip(keys, cm_deg))},
            "valve_mean_abs_step_v_per_tick": [valve[0]] * 5 + [2 * valve[0]],
            "valve_saturated_fraction": [valve[1]] * 5 + [4 * valve[1]]}


def results_for(seed, scale, combined_x=0.1):
    sessions = {t: report([scale * 0.1] * 6) for t in upt.TRAJ}
    sessions["combined"] = report([combined_x] + [scale * 0.1] * 5, (0.2 * scale, 0.01))
    return {"sessions": sessions, "in_process": None, "commands": []}


class Tables(unittest.TestCase):
    def test_cells_are_the_median_over_seeds_against_one_fifth_of_the_paper(self):
        # combined x: 0.100, 0.300, 0.200 cm -> median 0.200 > 0.845 / 5 = 0.169 (ratio 1.18);
        # every other cell 0.1 * median(1, 3, 2) = 0.2: at most one fifth on roll, pitch, yaw
        # and combined y, roll, pitch, yaw (7 cells); above it on x, y, z and combined z.
        res = {1: results_for(1, 1.0, 0.1), 2: results_for(2, 3.0, 0.3), 3: results_for(3, 2.0, 0.2)}
        s = upt.format_section(res, [1, 2, 3], "cmd", "2026-12-07", "abc1234")
        self.assertIn("| combined | x | 0.200 | 0.845 | 0.169 | 1.18 | NO | 0.100 | 0.300 | 0.200 |", s)
        self.assertIn("| x | x | 0.200 | 0.782 | 0.156 | 1.28 | NO |", s)
        self.assertIn("| roll | roll | 0.200 | 1.012 | 0.202 | 0.99 | yes |", s)
        self.assertIn("| combined | yaw | 0.200 | 2.433 | 0.487 | 0.41 | yes |", s)
        self.assertIn("7 of the 12 cells at most one fifth of the paper.", s)
        self.assertIn("seed 2: 0.700 V per tick, 1.50 % (4.00 %)", s)  # 0.6 x (5 + 2) / 6
        self.assertIn("| Table 10 layout (combined): BS-SMC, calibrated, DDS | 0.200 | 0.200 |", s)

    def test_a_session_without_tracking_gives_no_figure_for_its_cells(self):
        res = {1: results_for(1, 1.0), 2: results_for(2, 1.0)}
        res[2]["sessions"]["z"] = {"tracking_pose_samples": 0, "rmse_vs_ground_truth": {}}
        res[1]["sessions"]["combined"] = None
        s = upt.format_section(res, [1, 2], "cmd", "2026-12-07", "abc1234")
        self.assertIn("| z | z | n/a | 0.197 | 0.039 | n/a | NO | 0.100 | n/a |", s)
        self.assertIn("seed 1: n/a; seed 2:", s)

    def test_the_in_process_comparison_reports_the_largest_difference(self):
        res = {1: results_for(1, 1.0)}
        res[1]["in_process"] = {t: [0.1] * 6 for t in upt.TRAJ}
        res[1]["in_process"]["pitch"] = [0.1, 0.1, 0.1, 0.1, 0.125, 0.1]
        s = upt.format_section(res, [1], "cmd", "2026-12-07", "abc1234")
        self.assertIn("seed 1: largest difference over the 7 x 6 figures 2.50e-02", s)
        del res[1]["in_process"]["yaw"]  # a trajectory missing in process is not "agreement"
        s = upt.format_section(res, [1], "cmd", "2026-12-07", "abc1234")
        self.assertIn("seed 1: largest difference over the 7 x 6 figures inf", s)

    def test_the_section_goes_before_the_dds_sessions_and_replaces_itself(self):
        with tempfile.TemporaryDirectory() as d:
            doc = os.path.join(d, "results.md")
            with open(doc, "w") as f:
                f.write("# Results\n\n## In process\n\nA\n\n## DDS sessions (seed 1)\n\nB\n")
            upt.write_doc(doc, upt.SECTION + " (one)\n\nfirst\n")
            upt.write_doc(doc, upt.SECTION + " (two)\n\nsecond\n")
            with open(doc) as f:
                text = f.read()
        self.assertEqual(text, "# Results\n\n## In process\n\nA\n\n" + upt.SECTION +
                         " (two)\n\nsecond\n\n## DDS sessions (seed 1)\n\nB\n")


class CoupledLegs(unittest.TestCase):
    def commands(self, coupled, trajectories=None):
        """run_seed's commands with the runs faked (hexa_calibrate writes its overlay)."""
        issued = []

        def fake_run(cmd, log_path, reuse_path=None):
            issued.append(cmd)
            if cmd[0].endswith("hexa_calibrate"):
                with open(cmd[cmd.index("--out") + 1], "w") as f:
                    f.write("")
            return 0, 0.0
        with tempfile.TemporaryDirectory() as d:
            os.makedirs(os.path.join(d, "seed1", "calibration"))
            a = types.SimpleNamespace(build="b", out=d, controller="bssmc", profile="realistic",
                                      timeout=0, rig=None, lockstep_lease=None, reuse=False,
                                      in_process=True, coupled_legs=coupled)
            if trajectories:
                a.trajectories = trajectories
            saved, upt.run = upt.run, fake_run
            try:
                upt.run_seed(a, 1, 150)
            finally:
                upt.run = saved
        return issued

    def test_the_trajectories_and_hexa_sim_couple_the_calibration_session_does_not(self):
        cmds = self.commands(True)
        calibration = [c for c in cmds if "calibration" in c and "--trajectory" in c]
        trajectories = [c for c in cmds if "--rig-overlay" in c and "--trajectory" in c]
        sim = [c for c in cmds if c[0].endswith("hexa_sim")]
        self.assertEqual(len(calibration), 1)
        self.assertEqual(len(trajectories), 7)
        self.assertEqual(len(sim), 1)
        self.assertNotIn("--coupled-legs", calibration[0])
        for c in trajectories + sim:
            self.assertIn("--coupled-legs", c)
        self.assertFalse(any("--coupled-legs" in c for c in self.commands(False)))

    def test_a_subset_runs_only_its_trajectories_and_one_hexa_sim_each(self):
        cmds = self.commands(False, ["z", "combined"])
        sessions = [c[c.index("--trajectory") + 1] for c in cmds
                    if "--rig-overlay" in c and not c[0].endswith("hexa_sim")]
        sim = [c[c.index("--trajectory") + 1] for c in cmds if c[0].endswith("hexa_sim")]
        self.assertEqual(sessions, ["z", "combined"])
        self.assertEqual(sim, ["z", "combined"])
        res = {1: results_for(1, 1.0)}
        s = upt.format_section(res, [1], "cmd", "2026-12-07", "abc1234", trajs=["z", "combined"])
        self.assertIn("for the trajectories z, combined", s)
        self.assertIn("(7 cells run; n/a: trajectory not run)", s)

    def test_the_section_names_the_coupled_law(self):
        res = {1: results_for(1, 1.0)}
        s = upt.format_section(res, [1], "cmd", "2026-12-07", "abc1234", coupled=True)
        self.assertIn("| Table 10 layout (combined): BS-SMC, coupled legs, calibrated, DDS |", s)
        self.assertIn("with `--coupled-legs`", s)
        self.assertNotIn("coupled", upt.format_section(res, [1], "cmd", "2026-12-07", "abc1234"))


if __name__ == "__main__":
    unittest.main()
