// Deterministic synthetic recording used by the recorder tests: one second of the system's
// topics (ticks 1..1000) with a few samples deliberately left out, so that every count and
// every loss figure is known exactly.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <string>

#include "hexa/recording/recording.hpp"
#include "recording.pb.h"

namespace hexa::recorder::test {

// Topic names as the comm layer names them (comm/include/hexa/comm/qos.hpp).
inline const std::map<std::string, uint64_t>& SynthExpectedCounts() {
  static const std::map<std::string, uint64_t> counts = {
      {"hexa_LegSensors", 6 * 1000 - 5},  // leg 3 misses ticks 100..104
      {"hexa_ValveCommand", 6 * 1000 - 1},  // leg 2 misses tick 500
      {"hexa_GroundTruth", 1000},
      {"hexa_ImuSample", 200 - 1},  // misses tick 50
      {"hexa_LegSetpoint", 6 * 200},
      {"hexa_PoseReport", 200},
      {"hexa_NodeStatus", 20},  // 2 nodes x 10, event topic
      {"hexa_FaultEvent", 2},
      {"hexa_OperatorCommand", 1},
  };
  return counts;
}
// The command-age histogram of the synthetic ground truth, per leg (bins 0, 1, 2, 3-7, 8-15,
// >= 16, none): leg 4 late at 10 of its 1000 ticks.
inline std::array<uint64_t, 7> SynthCommandAges(int leg) {
  if (leg == 4) return {990, 0, 3, 7, 0, 0, 0};
  return {1000, 0, 0, 0, 0, 0, 0};
}
// The legs' adapted friction scale theta in the synthetic ValveCommands: a saw per leg with
// distinct values per leg; ticks 1..4 (before the first TRACKING pose report) read 0.5, outside
// every leg's range in the tracking window (ticks 5..1000).
inline double SynthFrictionScale(uint32_t leg, uint64_t tick) {
  if (tick < 5) return 0.5;
  return 1.0 + 0.01 * leg + 1e-4 * static_cast<double>((tick + 10 * leg) % 250);
}
// Who wrote the synthetic ValveCommands: the BS-SMC (theta as above), the BS-SMC of a recorder
// before the field existed (no friction_scale), or the PI baseline (theta 1).
enum class SynthController { kBsSmc, kBsSmcWithoutFrictionScale, kPi };
inline constexpr uint64_t kSynthStartNs = 1'700'000'000'000'000'000ull;

inline void FillHeader(rec::SampleHeader* h, uint64_t tick) {
  h->set_tick(tick);
  h->set_sim_time_s(static_cast<double>(tick) * 1e-3);
  h->set_source_time_ns(static_cast<int64_t>(kSynthStartNs + tick * 1'000'000ull));
}

// Writes the synthetic recording; valve_offset_v shifts every valve_v of leg
// `offset_leg` from tick `offset_from_tick` on (for diff tests).
// invalid_utf8_detail: the two FaultEvent details hold bytes that are not UTF-8 (as recorders
// before the sanitiser wrote them when a node published such text).
inline void WriteSynthRecording(const std::string& path, McapWriterConfig config = {},
                                double valve_offset_v = 0.0, uint32_t offset_leg = 0,
                                uint64_t offset_from_tick = 0, bool invalid_utf8_detail = false,
                                SynthController controller = SynthController::kBsSmc) {
  config.sync = McapSyncMode::kNone;
  RecordingWriter w(config);
  w.Open(path);
  auto meta = [](const char* period, const char* reliability) {
    return std::map<std::string, std::string>{{kMetaPeriodS, period},
                                              {"qos.reliability", reliability}};
  };
  const uint16_t c_sens = w.AddTopic("hexa_LegSensors", *rec::LegSensors::descriptor(),
                                     meta("0.001", "reliable"));
  const uint16_t c_valve = w.AddTopic("hexa_ValveCommand", *rec::ValveCommand::descriptor(),
                                      meta("0.001", "reliable"));
  const uint16_t c_gt = w.AddTopic("hexa_GroundTruth", *rec::GroundTruth::descriptor(),
                                   meta("0.001", "reliable"));
  const uint16_t c_imu = w.AddTopic("hexa_ImuSample", *rec::ImuSample::descriptor(),
                                    meta("0.005", "reliable"));
  const uint16_t c_sp = w.AddTopic("hexa_LegSetpoint", *rec::LegSetpoint::descriptor(),
                                   meta("0.005", "reliable"));
  const uint16_t c_pose = w.AddTopic("hexa_PoseReport", *rec::PoseReport::descriptor(),
                                     meta("0.005", "reliable"));
  const uint16_t c_node = w.AddTopic("hexa_NodeStatus", *rec::NodeStatus::descriptor(),
                                     meta("0", "reliable"));
  const uint16_t c_fault = w.AddTopic("hexa_FaultEvent", *rec::FaultEvent::descriptor(),
                                      meta("0", "reliable"));
  const uint16_t c_op = w.AddTopic("hexa_OperatorCommand", *rec::OperatorCommand::descriptor(),
                                   meta("0", "reliable"));
  auto put = [&](uint16_t ch, uint64_t tick, uint64_t extra_ns,
                 const google::protobuf::Message& m) {
    const uint64_t source = kSynthStartNs + tick * 1'000'000ull;
    w.Write(ch, source + 50'000 + extra_ns, source, m);
  };
  for (uint64_t tick = 1; tick <= 1000; ++tick) {
    if (tick == 1) {
      rec::OperatorCommand op;
      op.set_sequence(1);
      op.set_kind(rec::OPERATOR_START);
      op.set_trajectory("combined");
      op.set_csv_path("/tmp/x, \"quoted\".csv");
      op.set_source_time_ns(static_cast<int64_t>(kSynthStartNs));
      put(c_op, tick, 0, op);
    }
    for (uint32_t leg = 1; leg <= 6; ++leg) {
      if (leg == 3 && tick >= 100 && tick <= 104) continue;
      rec::LegSensors s;
      s.set_leg_id(leg);
      FillHeader(s.mutable_header(), tick);
      s.set_length_m(0.5034 + 1e-4 * static_cast<double>(tick % 97) + 1e-3 * leg);
      s.set_cap_pressure_pa(4e5 + static_cast<double>(tick));
      s.set_rod_pressure_pa(3e5 - static_cast<double>(tick));
      s.set_supply_pressure_pa(7e5);
      put(c_sens, tick, leg * 1000, s);
    }
    for (uint32_t leg = 1; leg <= 6; ++leg) {
      if (leg == 2 && tick == 500) continue;
      rec::ValveCommand v;
      v.set_leg_id(leg);
      FillHeader(v.mutable_header(), tick);
      double valve = 5.0 + 0.001 * static_cast<double>(tick % 100) * leg;
      if (leg == offset_leg && tick >= offset_from_tick) valve += valve_offset_v;
      v.set_valve_v(valve);
      v.set_controller(controller == SynthController::kPi ? rec::CONTROLLER_PI
                                                          : rec::CONTROLLER_BSSMC);
      v.set_status(rec::LEGCTRL_OK);
      v.set_setpoint_tick(tick - tick % 5);
      v.set_desired_length_m(0.5);
      v.set_sliding_surface_m_s(-0.01);
      v.set_compute_time_s(2e-5);
      if (controller == SynthController::kBsSmc) v.set_friction_scale(SynthFrictionScale(leg, tick));
      if (controller == SynthController::kPi) v.set_friction_scale(1.0);
      put(c_valve, tick, 200'000 + leg * 1000, v);
    }
    rec::GroundTruth g;
    FillHeader(g.mutable_header(), tick);
    for (int i = 0; i < 3; ++i) g.add_position_m(0.01 * i);
    for (int i = 0; i < 4; ++i) g.add_orientation_wxyz(i == 0 ? 1.0 : 0.0);
    for (int i = 0; i < 3; ++i) g.add_linear_velocity_m_s(0.0);
    for (int i = 0; i < 3; ++i) g.add_angular_velocity_rad_s(0.0);
    for (int i = 0; i < 6; ++i) {
      g.add_leg_length_m(0.5);
      g.add_piston_velocity_m_s(0.0);
      g.add_cap_pressure_pa(4e5);
      g.add_rod_pressure_pa(3e5);
      g.add_spool_position_m(0.0);
      g.add_applied_valve_v(5.0);
      // Leg 4's command comes late at ticks 300..309: 2 ticks old, then 5 (SynthCommandAges).
      const bool late4 = i == 3 && tick >= 300 && tick < 310;
      g.add_command_age_ticks(late4 ? (tick < 303 ? 2 : 5) : 0);
    }
    put(c_gt, tick, 10'000, g);
    if (tick % 5 == 0) {
      if (tick != 50) {
        rec::ImuSample imu;
        FillHeader(imu.mutable_header(), tick);
        for (double q : {1.0, 0.0, 0.0, 0.0}) imu.add_orientation_wxyz(q);
        for (int i = 0; i < 3; ++i) imu.add_angular_rate_rad_s(0.001 * i);
        put(c_imu, tick, 20'000, imu);
      }
      for (uint32_t leg = 1; leg <= 6; ++leg) {
        rec::LegSetpoint sp;
        sp.set_leg_id(leg);
        FillHeader(sp.mutable_header(), tick);
        sp.set_length_m(0.5);
        sp.set_velocity_m_s(0.1);
        sp.set_acceleration_m_s2(0.2);
        sp.set_correction_m(1e-4);
        sp.set_hold(false);
        put(c_sp, tick, 30'000 + leg * 100, sp);
      }
      rec::PoseReport p;
      FillHeader(p.mutable_header(), tick);
      p.set_state(rec::SUPERVISOR_TRACKING);
      p.set_trajectory_time_s(static_cast<double>(tick) * 1e-3);
      for (int i = 0; i < 6; ++i) {
        p.add_desired_pose(0.01 * i);
        p.add_estimated_pose(0.01 * i + 1e-4);
        p.add_error_pose(-1e-4);
      }
      p.set_estimator_status(0);
      p.set_excluded_leg(-1);
      put(c_pose, tick, 40'000, p);
    }
    if (tick % 100 == 0) {
      for (const char* node : {"plant_sim", "task_space"}) {
        rec::NodeStatus n;
        n.set_node_name(node);
        FillHeader(n.mutable_header(), tick);
        n.set_state(rec::NODE_RUNNING);
        n.set_cycles_total(tick);
        n.set_detail("ok");
        put(c_node, tick, 60'000, n);
      }
    }
    if (tick == 300 || tick == 301) {
      rec::FaultEvent f;
      f.set_source_node("plant_sim");
      f.set_leg_id(4);
      f.set_tick(tick);
      f.set_reason(rec::FAULT_COMMAND_STALE);
      f.set_detail(invalid_utf8_detail ? std::string("bad header \"\xff\xfe\xc0\xaf\x80\"") : "synthetic");
      f.set_source_time_ns(static_cast<int64_t>(kSynthStartNs + tick * 1'000'000ull));
      put(c_fault, tick, 70'000, f);
    }
  }
  w.Close();
}

}  // namespace hexa::recorder::test
