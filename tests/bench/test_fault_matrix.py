#!/usr/bin/python3
"""Unit tests of the fault matrix's analysis (bench/faults/fault_matrix.py): pure functions on
recorded rows, no session run."""
import os
import sys
import unittest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "bench", "faults"))
import fault_matrix  # noqa: E402


def cmd(leg, tick, standby, t_ms):
    return {"leg_id": str(leg), "header.tick": str(tick), "standby": "1" if standby else "0",
            "publish_time_ns": str(int(t_ms * 1e6))}


class GroundTruthPose(unittest.TestCase):
    def test_reads_the_exported_axis_columns(self):
        # hexa_recorder export's header cells "position_m.x [m]" ..., keyed without the unit.
        row = {"position_m.x": "0.1", "position_m.y": "-0.2", "position_m.z": "0.7",
               "orientation_wxyz.w": "1", "orientation_wxyz.x": "0", "orientation_wxyz.y": "0.5",
               "orientation_wxyz.z": "0"}
        p, q = fault_matrix.pose_of(row)
        self.assertEqual(p, [0.1, -0.2, 0.7])
        self.assertEqual(q, [1.0, 0.0, 0.5, 0.0])

    def test_reads_indexed_columns_too(self):
        row = {"position_m[%d]" % k: str(k) for k in range(3)}
        row.update({"orientation_wxyz[%d]" % k: str(k + 10) for k in range(4)})
        self.assertEqual(fault_matrix.pose_of(row), ([0.0, 1.0, 2.0], [10.0, 11.0, 12.0, 13.0]))


class TakeOver(unittest.TestCase):
    def test_is_measured_from_the_primarys_last_command(self):
        # The standby's samples at tick 0 and at tick 812 (a primary late past its deadline) came
        # before the fault: the take-over is 1510 ms - 1499 ms, not the 0.9 ms of tick 812.
        rows = [cmd(2, 0, True, 0.0)] + [cmd(2, n, False, n) for n in range(0, 812)]
        rows += [cmd(2, 812, True, 812.9)] + [cmd(2, n, False, n) for n in range(812, 1500)]
        rows += [cmd(2, n, True, n + 11.0) for n in range(1499, 1600)]
        rows += [cmd(3, n, False, n) for n in range(0, 1600)]  # another leg is not mixed in
        takeover_ms, gap_ms = fault_matrix.takeover(rows, 2)
        self.assertAlmostEqual(takeover_ms, 11.0, places=6)
        self.assertAlmostEqual(gap_ms, 1.0, places=6)

    def test_a_gap_after_the_take_over_is_reported(self):
        rows = [cmd(1, n, False, n) for n in range(0, 1500)]
        rows += [cmd(1, n, True, n + 10.5) for n in range(1499, 3000)]
        rows += [cmd(1, n, True, n + 30.0) for n in range(3000, 3100)]  # 19.5 ms without a command
        takeover_ms, gap_ms = fault_matrix.takeover(rows, 1)
        self.assertAlmostEqual(takeover_ms, 10.5, places=6)
        self.assertAlmostEqual(gap_ms, 20.5, places=6)

    def test_no_standby_command_after_the_primary_means_no_take_over(self):
        rows = [cmd(4, 0, True, 0.0)] + [cmd(4, n, False, n) for n in range(0, 100)]
        self.assertEqual(fault_matrix.takeover(rows, 4), (None, None))


class InfoLoss(unittest.TestCase):
    # The "loss from tick numbers" block as `hexa_recorder info` prints it.
    INFO = """loss from tick numbers (per instance):
  hexa_LegSensors              leg 1        ticks 0..5060 step 1: 5061 received, 5061 expected, 0 missing in 0 gaps (largest 1 ticks), 0 duplicate/reordered
  hexa_LegSensors              leg 6        ticks 0..5060 step 1: 5051 received, 5061 expected, 10 missing in 2 gaps (largest 6 ticks), 0 duplicate/reordered
  hexa_ValveCommand            leg 3        ticks 0..5060 step 1: 5050 received, 5061 expected, 11 missing in 1 gaps (largest 12 ticks), 0 duplicate/reordered
  hexa_GroundTruth             -            ticks 0..5060 step 1: 5061 received, 5061 expected, 0 missing in 0 gaps (largest 1 ticks), 0 duplicate/reordered
"""

    def test_per_leg_instances_are_read(self):
        # Before: the key pattern took one word, so every "leg N" line (LegSensors,
        # ValveCommand) was skipped and their losses were never counted.
        loss = fault_matrix.parse_info_loss(self.INFO)
        self.assertEqual(loss[("hexa_LegSensors", "leg 6")]["missing"], 10)
        self.assertEqual(loss[("hexa_LegSensors", "leg 6")]["gaps"], 2)
        self.assertEqual(loss[("hexa_ValveCommand", "leg 3")]["gaps"], 1)
        self.assertEqual(loss[("hexa_GroundTruth", "-")]["missing"], 0)
        self.assertEqual(len(loss), 4)


class Stalls(unittest.TestCase):
    PROBE = {"per_cpu": [{"cpu": 0, "max_late_us": 17825, "over_5ms": 1},
                         {"cpu": 1, "max_late_us": 2100, "over_5ms": 0}],
             "events": [{"cpu": 0, "due_realtime_ns": 1000000000, "late_us": 17825, "steal_jiffies": 0},
                        {"cpu": 1, "due_realtime_ns": 5000000000, "late_us": 2100, "steal_jiffies": 1}]}

    def test_summary_names_each_cpus_largest_stall(self):
        self.assertEqual(fault_matrix.stall_summary(self.PROBE), "cpu0 17.8 ms (1 > 5 ms), cpu1 2.1 ms")
        self.assertEqual(fault_matrix.stall_summary(None), "-")

    def test_stall_before_a_fault_is_found_only_in_its_window(self):
        # The fault 30 ms after the stall ended: inside the 40 ms window.
        t = 1000000000 + 17825000 + 30000000
        self.assertEqual(fault_matrix.stall_before(self.PROBE, t), "cpu0 17.8 ms (steal 0 jiffies)")
        # 100 ms later: no stall in the window.
        self.assertIsNone(fault_matrix.stall_before(self.PROBE, t + 100000000))


if __name__ == "__main__":
    unittest.main()
