// The plant node's device side: bringing the rig behind the seam up (the simulation, or a
// remote I/O board: link open, power-up e-stop latch reset with the loop closed, a first
// sample), and one exchange per tick: write the valves, read the next sample. On a board the
// exchange also judges the link (a tick without an intact frame; lost after
// BoardLinkOptions::lost_after_ticks) and the e-stop latch the board reports (a FaultEvent
// naming its source: the supervisor holds). The control round trip (a sample read -> the
// command computed from it written) is measured on either device.
#include <cstdio>
#include <stdexcept>
#include <string>

#include "plant_node.hpp"

namespace hexa::plant_sim {
namespace {

std::string BoardAddress(const BoardLinkOptions& b) { return b.host + ":" + std::to_string(b.port); }

// Which input set the latch, for the operator.
const char* EstopSource(const device::DeviceSafety& s) {
  if (s.estop_by_input) return "the e-stop loop opened (board input)";
  if (s.estop_by_host) return "an e-stop command from the host";
  if (s.estop_at_power_up) return "latched since the board's power-up";
  return "latched";
}

}  // namespace

void PlantNode::BringUpDevice() {
  std::string error;
  if (!device_.Configure(error)) {
    throw std::invalid_argument(board_ ? "--board-address " + BoardAddress(options_.board) + ": " + error
                                       : "device: " + error);
  }
  if (board_ == nullptr) {
    device_.ReadSensors(sensors_);
    return;
  }
  // A board powers up with its e-stop latched: one reset request (a run of frames with the
  // reset bit) while safe commands keep its watchdog fed; the loop must be closed. In
  // lockstep (the emulator in step mode) each command is one board tick: every frame is
  // awaited, so that the bring-up takes the same ticks every run.
  // At most 50 commands; the board must answer each within the timeout in lockstep, and
  // within the timeout from the first command in real time.
  const bool lockstep = options_.common.mode == node::TimeMode::kLockstep;
  const double timeout_s = options_.board.answer_timeout_s;
  const std::int64_t end_ns = node::MonotonicNow_ns() + static_cast<std::int64_t>(timeout_s * 1e9);
  device_.RequestEstopReset();
  bool answered = false;
  int commands = 0;
  for (int frame = 0; frame < 50; ++frame) {
    ++commands;
    if (frame > 0 && frame % 10 == 0 && sensors_.safety.estop_latched) device_.RequestEstopReset();
    device_.WriteSafeState();
    const bool readable = board_->WaitForData(lockstep ? timeout_s : 0.005);
    if (readable && device_.ReadSensors(sensors_) == device::DeviceStatus::kOk) {
      answered = true;
      if (frame >= 4 && !sensors_.safety.estop_latched) break;
    } else if ((lockstep && !readable) || node::MonotonicNow_ns() > end_ns) {
      break;  // lockstep: a refused frame (a lost one's empty datagram) is an answer; silence is not
    }
  }
  if (!answered) {
    throw std::invalid_argument("--board-address " + BoardAddress(options_.board) +
                                ": the board does not answer (no intact sensor frame within " +
                                std::to_string(timeout_s) + " s of a command; datagrams refused: " +
                                board_->counters().Describe() + ")");
  }
  if (sensors_.safety.estop_latched) {
    throw std::invalid_argument("board at " + BoardAddress(options_.board) + ": e-stop latched (" +
                                EstopSource(sensors_.safety) + (sensors_.safety.estop_loop_open
                                ? "; the loop reads open: close it" : "; the reset was refused") + ")");
  }
  log_->info("board at {} answers: e-stop loop closed, latch reset after {} safe-state commands; "
             "link: {}", BoardAddress(options_.board), commands, board_->counters().Describe());
}

device::DeviceStatus PlantNode::ExchangeWithDevice(const LegArray<double>& valve_v) {
  const std::int64_t written_ns = node::MonotonicNow_ns();
  const device::DeviceStatus written = device_.WriteValves(valve_v);
  if (sample_read_ns_ >= 0) {
    round_trip_.Add(written_ns - sample_read_ns_);
    sample_read_ns_ = -1;
  }
  if (written == device::DeviceStatus::kFault) return written;
  // Lockstep on a board: the emulator in step mode answers this command with the next frame
  // (not awaited again once the board is lost: the loop ticks on so that the supervisor holds).
  bool timed_out = false;
  const device::DeviceStatus read = board_ != nullptr && options_.common.mode == node::TimeMode::kLockstep &&
                                            !board_down_
                                        ? ReadBoardAnswer(timed_out)
                                        : device_.ReadSensors(sensors_);
  if (board_ != nullptr) ReportRefusedFrames();
  if (read == device::DeviceStatus::kOk) {
    sample_read_ns_ = node::MonotonicNow_ns();
    if (board_down_)
      log_->warn("tick {}: the board answers again after {} ticks without a frame; link: {}", tick_,
                 ticks_without_sample_, board_->counters().Describe());
    board_down_ = false;
    ticks_without_sample_ = 0;
    return written;
  }
  // No new sample this tick: the last one is published again (a frame lost, refused or late;
  // in real time also the board's and this loop's clocks, which are not locked).
  ++samples_missed_total_;
  ++ticks_without_sample_;
  const bool lost = timed_out || ticks_without_sample_ >= options_.board.lost_after_ticks;
  if (board_ != nullptr && lost && !board_down_) {
    board_down_ = true;
    device_lost_ = true;
    char detail[160];
    std::snprintf(detail, sizeof detail, "board %s: no intact sensor frame for %llu ticks (%s; %s%s)",
                  BoardAddress(options_.board).c_str(),
                  static_cast<unsigned long long>(ticks_without_sample_), device::ToString(read),
                  LastOutOfRange().c_str(), board_->counters().Describe().c_str());
    faults_.Publish(0, tick_, hexa_msg_FAULT_BOARD_LINK, detail);
    log_->error("tick {}: FAULT_BOARD_LINK: {}: the last sample is published on, the supervisor "
                "holds, the board's watchdog holds the valves safe", tick_, detail);
  }
  return written;
}

device::DeviceStatus PlantNode::ReadBoardAnswer(bool& timed_out) {
  // The emulator in step mode answers each command with one datagram: an intact frame, or
  // one refused (a bad CRC, an old version, a value out of range; the empty datagram of a
  // frame the link lost). A frame not newer than the last accepted one is a late frame of an
  // earlier tick, not this command's answer: the wait goes on.
  auto answers = [this] {
    const device::BoardLinkCounters& c = board_->counters();
    std::uint64_t n = 0;
    for (std::size_t v = 0; v < device::kFrameVerdictCount; ++v) n += c.frames[v];
    return n - c[device::FrameVerdict::kOldSequence] - c[device::FrameVerdict::kUnknownSender];
  };
  const std::uint64_t before = answers();
  const std::int64_t end_ns =
      node::MonotonicNow_ns() + static_cast<std::int64_t>(options_.board.answer_timeout_s * 1e9);
  for (;;) {
    const double left_s = static_cast<double>(end_ns - node::MonotonicNow_ns()) * 1e-9;
    if (left_s <= 0.0 || !board_->WaitForData(left_s)) {
      timed_out = true;
      return device_.ReadSensors(sensors_);
    }
    const device::DeviceStatus read = device_.ReadSensors(sensors_);
    if (read != device::DeviceStatus::kNoNewData || answers() != before) return read;
  }
}

void PlantNode::ReportRefusedFrames() {
  // The first datagram of each refusing verdict is logged with its cause; every one is counted
  // (the end's log line, plant.json "board_link").
  const device::BoardLinkCounters& c = board_->counters();
  for (std::size_t v = 1; v < device::kFrameVerdictCount; ++v) {
    if (c.frames[v] == 0 || link_reported_.frames[v] != 0) continue;
    const auto verdict = static_cast<device::FrameVerdict>(v);
    log_->warn("tick {}: a datagram from the board refused: {}{} (the first; the tick republishes the "
               "last sample, every refusal is counted)", tick_, device::ToString(verdict),
               verdict == device::FrameVerdict::kOutOfRange ? " (" + LastOutOfRange() + ")" : std::string());
  }
  link_reported_ = c;
}

std::string PlantNode::LastOutOfRange() const {
  const int channel = board_->decoder().last_out_of_range_channel();
  if (channel < 0) return "";
  char text[96];
  std::snprintf(text, sizeof text, "%s = %.4g out of its range; ", device::BoardChannelName(channel).c_str(),
                board_->decoder().last_out_of_range_value_si());
  return text;
}

void PlantNode::JudgeDeviceSafety() {
  const device::DeviceSafety& s = sensors_.safety;
  if (!s.estop_latched) {
    if (estop_reported_) log_->warn("tick {}: e-stop latch reset: the valves follow the commands again", tick_);
    estop_reported_ = false;
    estop_reset_asked_ = false;
    return;
  }
  if (!s.valves_safe) ++estop_unsafe_ticks_;  // the device's own word; never expected
  if (estop_reset_asked_ && s.reset_refused) {
    // The supervisor left HOLD on the same reset: it holds again on this report.
    estop_reset_asked_ = false;
    char detail[160];
    std::snprintf(detail, sizeof detail, "e-stop reset refused by the rig: %s",
                  s.estop_loop_open ? "the e-stop loop is still open: close it, then reset"
                                    : "the e-stop is still asked");
    faults_.Publish(0, tick_, hexa_msg_FAULT_ESTOP, detail);
    log_->error("tick {}: FAULT_ESTOP: {}", tick_, detail);
  }
  if (estop_reported_) return;
  estop_reported_ = true;
  // The sample that shows the latch first: its board time (the tick the input was sampled)
  // and whether every valve output was already at its safe value in that same tick.
  char detail[160];
  std::snprintf(detail, sizeof detail, "e-stop: %s; valves %s at device tick %.0f",
                EstopSource(s), s.valves_safe ? "all at their safe value" : "NOT all safe",
                sensors_.device_time_s * 1e3);
  faults_.Publish(0, tick_, hexa_msg_FAULT_ESTOP, detail);
  log_->error("tick {}: FAULT_ESTOP: {} (applied [{:.3f} {:.3f} {:.3f} {:.3f} {:.3f} {:.3f}] V); "
              "re-arm: close the loop, then an operator reset", tick_, detail,
              sensors_.applied_valve_v[0], sensors_.applied_valve_v[1], sensors_.applied_valve_v[2],
              sensors_.applied_valve_v[3], sensors_.applied_valve_v[4], sensors_.applied_valve_v[5]);
}

void PlantNode::LatchOperatorEstop(std::uint32_t sequence) {
  if (operator_estop_sequence_ == sequence) return;  // the same command by the other path
  operator_estop_sequence_ = sequence;
  device_.LatchEstop();  // the valves to their safe values from this tick's write on
  char detail[160];
  std::snprintf(detail, sizeof detail, "e-stop: operator command #%u: every valve to its safe "
                "value from tick %llu", static_cast<unsigned>(sequence), static_cast<unsigned long long>(tick_));
  faults_.Publish(0, tick_, hexa_msg_FAULT_ESTOP, detail);
  log_->error("tick {}: FAULT_ESTOP: {}", tick_, detail);
}

void PlantNode::TakeOperatorCommands() {
  // The supervisor's word on an operator e-stop (a FaultEvent) when this reader missed it;
  // real time: every 10 ticks with the interlock (RunRealtime), lockstep: every tick.
  if (options_.common.mode == node::TimeMode::kLockstep) TakeFaultEvents();
  while (operator_reader_.Take() > 0) {
    for (std::size_t k = 0; k < operator_reader_.count(); ++k) {
      if (!operator_reader_.info(k).valid_data) continue;
      const hexa_msg_OperatorCommand& c = operator_reader_.sample(k);
      if (c.kind != hexa_msg_OPERATOR_ESTOP && c.kind != hexa_msg_OPERATOR_RESET) continue;
      // Only the session's operator tools (docs/faults.md, "Foreign commands").
      const comm::CommandTrust trust = operator_reader_.Authenticate(k);
      if (!comm::Trusted(trust)) {
        refusals_.Refuse(operator_reader_.get(), operator_reader_.info(k), trust, "OperatorCommand", 0,
                         tick_, faults_, *log_);
        continue;
      }
      if (c.kind == hexa_msg_OPERATOR_ESTOP) {
        LatchOperatorEstop(c.sequence);
      } else if (sensors_.safety.estop_latched) {
        device_.RequestEstopReset();  // the rig refuses while its loop is open
        estop_reset_asked_ = true;
        operator_estop_sequence_ = 0;
        log_->warn("tick {}: operator reset #{}: e-stop reset asked of the rig", tick_,
                   static_cast<unsigned>(c.sequence));
      }
    }
  }
}

void PlantNode::LogDeviceEnd() const {
  log_->info("control round trip (sample read from the device -> the command computed from it "
             "written): median {:.3f} ms, p99 {:.3f} ms, max {:.3f} ms over {} ticks; ticks "
             "without a new sample {}",
             round_trip_.Quantile_s(0.5) * 1e3, round_trip_.Quantile_s(0.99) * 1e3, round_trip_.max_s() * 1e3,
             round_trip_.count(), samples_missed_total_);
  if (estop_unsafe_ticks_ > 0)
    log_->error("e-stop: {} ticks latched with a valve not at its safe value (the device's report)",
                estop_unsafe_ticks_);
  if (board_ != nullptr) {
    log_->info("board link: received {}; send errors {}, receive errors {}; commands clamped {}, "
               "non-finite {}", board_->counters().Describe(), board_->send_errors(),
               board_->receive_errors(), board_->encoder().clamped_values(),
               board_->encoder().non_finite_values());
  }
}

}  // namespace hexa::plant_sim
