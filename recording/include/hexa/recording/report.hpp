// The session report, computed from a recording alone: task-space RMSE per axis against
// ground truth and against the measured pose (GQFK + IMU) over the supervisor's TRACKING
// window (paper Tables 9 / 10), leg-length RMSE per leg, deadline misses per topic, control
// round-trip latency (sensor sample written -> valve command written, same leg and tick),
// wall and simulated time, faults. Same definitions as hexa::RunPaperSession.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "hexa/core/metrics.hpp"

namespace hexa::recorder {

struct SessionReport {
  std::string recording;
  std::map<std::string, std::string> meta;  // trajectory, controller, profile, mode, seed...
  bool complete_file = false;
  std::uint64_t pose_samples_tracking = 0;
  std::array<double, 6> rmse_vs_truth{};      // m, m, m, rad, rad, rad
  std::array<double, 6> relative_vs_truth{};  // RMSE / desired peak-to-peak; < 0: no motion
  std::array<double, 6> rmse_vs_measured{};
  std::array<double, 6> relative_vs_measured{};
  std::array<double, 6> leg_length_rmse_m{};
  std::array<double, 6> leg_length_max_abs_m{};
  // Valve activity over the tracking window (applied voltages): mean |u(k) - u(k-1)| per
  // 1 ms tick, and the fraction of ticks at either end of the range (chattering shows here).
  std::array<double, 6> valve_mean_abs_step_v{};
  std::array<double, 6> valve_saturated_fraction{};
  Percentiles latency_s;                      // sensor written -> command written
  std::uint64_t latency_pairs = 0;
  std::map<std::string, std::uint64_t> deadline_misses;  // per topic (from NodeStatus)
  // Age of the command the plant applied, per leg, from GroundTruth.command_age_ticks: tick -
  // the tick the command answered. Bins 0, 1, 2, 3-7, 8-15, >= 16, no command yet. A command
  // older than the sensor sample just before it (age >= 1) came too late: a late tick, the
  // figure that matters to control (the raw DDS deadline misses above count every late
  // sample against a 1 ms deadline on a machine that does not keep 1 ms).
  static constexpr int kAgeBins = 7;
  std::array<std::array<std::uint64_t, kAgeBins>, 6> command_age{};
  bool command_age_recorded = false;  // recordings before the field existed have none
  // Adapted friction scale theta of the BS-SMC (ValveCommand.friction_scale), per leg over the
  // tracking window: the value of the leg's last command in it, and the smallest and largest.
  // Taken from the BS-SMC's commands only (the first recorded one per tick, as the leg-length
  // figures): `bssmc_commands` = 0 for a PI or open-loop leg, and no figure then. `commands` =
  // those that carry the field (0 in a recording made before the field existed).
  struct FrictionScale {
    std::uint64_t bssmc_commands = 0;
    std::uint64_t commands = 0;
    double end = 0.0, min = 0.0, max = 0.0;
  };
  std::array<FrictionScale, 6> friction_scale{};
  bool AnyBsSmcLeg() const {
    for (const auto& f : friction_scale)
      if (f.bssmc_commands > 0) return true;
    return false;
  }
  std::map<std::string, std::uint64_t> messages;         // per topic
  std::map<std::string, std::uint64_t> missing;          // per periodic topic, from ticks
  std::vector<std::string> faults;                       // FaultEvent lines
  // Hot-standby take-overs: one line per leg whose standby's commands follow the primary's
  // last (the recorder reads ValveCommand with exclusive ownership, as the plant does, so a
  // standby's commands appear only once it owns the valve). No FaultEvent says this.
  std::vector<std::string> takeovers;
  // Samples the recording lacks in the plant's streams (LegSensors, GroundTruth, ImuSample:
  // one per tick or per IMU period whatever the controllers do), from their tick numbers:
  // samples the recorder lost. `expected`: what those streams should hold.
  std::uint64_t recording_lost_samples = 0;
  std::uint64_t recording_expected_samples = 0;
  std::vector<std::string> warnings;  // what the reader repaired (invalid UTF-8), per channel
  double wall_time_s = 0.0;   // first to last log time
  double sim_time_s = 0.0;    // last ground-truth tick
  std::string final_supervisor_state;
  // Per-tick series for the plots (pose every 5 ms, legs every 1 ms).
  struct PoseRow {
    double time_s;
    std::array<double, 6> desired, truth, measured;
  };
  struct LegRow {
    double time_s;
    std::array<double, 6> desired_length_m, measured_length_m, valve_v;
    std::array<double, 6> friction_scale;  // NaN: no command, or the field not recorded
  };
  std::vector<PoseRow> pose_rows;
  // What happened, for the plots' markers (events.csv, report_events.cpp): supervisor state
  // changes (the tracking window, HOLD), faults, hot-standby take-overs, operator commands.
  struct Event {
    double time_s;      // simulated time of the tick
    std::string kind;   // "state", "fault", "takeover", "operator"
    int leg;            // 1..6, 0 when no leg is concerned
    std::string label;  // short text for the plot
  };
  std::vector<Event> events;
  std::vector<LegRow> leg_rows;
  // Valve voltages the plant applied, per tick (from GroundTruth), for bit-exact comparisons;
  // NaN for a tick whose GroundTruth sample is not in the recording.
  std::vector<std::array<double, 6>> applied_valve_v;
  // ValveCommand.friction_scale per command tick (the first recorded command of the leg and
  // tick), for the same comparisons; NaN where there is none or it does not carry the field.
  std::vector<std::array<double, 6>> command_friction_scale;
  // ValveCommand.coupled per command tick likewise: 1 coupled, 0 not, -1 no command.
  std::vector<std::array<int, 6>> command_coupled;
};

// Throws McapError / std::runtime_error with a message naming the file on a bad recording.
// `progress` (optional) hears the fraction of the work done, 0..1: the recording is read twice
// (the figures, then the loss analysis of hexa_recorder info), each read half of it.
SessionReport ComputeSessionReport(const std::string& recording_path,
                                   const std::function<void(double fraction)>& progress = {});
// A recording split into parts (hexa_recorder record --split-*), oldest first: one report
// over all of them, as if they were one file.
SessionReport ComputeSessionReport(const std::vector<std::string>& parts,
                                   const std::function<void(double fraction)>& progress = {});

// Writes report.json, report.md, pose.csv, legs.csv into `out_dir`.
void WriteSessionReport(const SessionReport& report, const std::string& out_dir);

}  // namespace hexa::recorder
