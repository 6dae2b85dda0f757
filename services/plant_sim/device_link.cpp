#include "device_link.hpp"

#include <cstdio>
#include <stdexcept>
#include <utility>

#include <spdlog/fmt/fmt.h>

namespace hexa::plant_sim {
namespace {

// Which input set the latch, for the operator.
const char* EstopSource(const device::DeviceSafety& s) {
  if (s.estop_by_input) return "the e-stop loop opened (board input)";
  if (s.estop_by_host) return "an e-stop command from the host";
  if (s.estop_at_power_up) return "latched since the board's power-up";
  return "latched";
}

}  // namespace

hexa_msg_FaultReason DeviceEvent::reason() const {
  return kind == Kind::kLinkLost ? hexa_msg_FAULT_BOARD_LINK : hexa_msg_FAULT_ESTOP;
}

DeviceEvent* DeviceEvents::Add(DeviceEvent::Kind kind, std::uint64_t tick) {
  if (size_ == kCapacity) return nullptr;
  DeviceEvent& e = events_[size_++];
  e.kind = kind;
  e.tick = tick;
  e.detail[0] = '\0';
  return &e;
}

DeviceLink::DeviceLink(device::Device& device, device::RemoteBoardDevice* board,
                       DeviceLinkParams params, Clock now_ns)
    : device_(device), board_(board), params_(std::move(params)), now_ns_(now_ns) {}

std::string DeviceLink::BringUp() {
  std::string error;
  if (!device_.Configure(error)) {
    throw std::invalid_argument(board_ ? "--board-address " + params_.address + ": " + error
                                       : "device: " + error);
  }
  if (board_ == nullptr) {
    device_.ReadSensors(sensors_);
    return {};
  }
  // A board powers up with its e-stop latched: one reset request (a run of frames with the
  // reset bit) while safe commands keep its watchdog fed; the loop must be closed. In
  // lockstep (the emulator in step mode) each command is one board tick: every frame is
  // awaited, so that the bring-up takes the same ticks every run.
  // At most 50 commands; the board must answer each within the timeout in lockstep, and
  // within the timeout from the first command in real time.
  const double timeout_s = params_.answer_timeout_s;
  const std::int64_t end_ns = now_ns_() + static_cast<std::int64_t>(timeout_s * 1e9);
  device_.RequestEstopReset();
  bool answered = false;
  int commands = 0;
  for (int frame = 0; frame < 50; ++frame) {
    ++commands;
    if (frame > 0 && frame % 10 == 0 && sensors_.safety.estop_latched) device_.RequestEstopReset();
    device_.WriteSafeState();
    const bool readable = board_->WaitForData(params_.lockstep ? timeout_s : 0.005);
    if (readable && device_.ReadSensors(sensors_) == device::DeviceStatus::kOk) {
      answered = true;
      if (frame >= 4 && !sensors_.safety.estop_latched) break;
    } else if ((params_.lockstep && !readable) || now_ns_() > end_ns) {
      break;  // lockstep: a refused frame (a lost one's empty datagram) is an answer; silence is not
    }
  }
  if (!answered) {
    throw std::invalid_argument("--board-address " + params_.address +
                                ": the board does not answer (no intact sensor frame within " +
                                std::to_string(timeout_s) + " s of a command; datagrams refused: " +
                                board_->counters().Describe() + ")");
  }
  if (sensors_.safety.estop_latched) {
    throw std::invalid_argument("board at " + params_.address + ": e-stop latched (" +
                                EstopSource(sensors_.safety) + (sensors_.safety.estop_loop_open
                                ? "; the loop reads open: close it" : "; the reset was refused") + ")");
  }
  return fmt::format("board at {} answers: e-stop loop closed, latch reset after {} safe-state "
                     "commands; link: {}", params_.address, commands, board_->counters().Describe());
}

device::DeviceStatus DeviceLink::Exchange(const LegArray<double>& valve_v, std::uint64_t tick,
                                          DeviceEvents& events, bool safe_state) {
  const std::int64_t written_ns = now_ns_();
  const device::DeviceStatus written = safe_state ? device_.WriteSafeState() : device_.WriteValves(valve_v);
  if (sample_read_ns_ >= 0) {
    round_trip_.Add(written_ns - sample_read_ns_);
    sample_read_ns_ = -1;
  }
  if (written == device::DeviceStatus::kFault) return written;
  // Lockstep on a board: the emulator in step mode answers this command with the next frame
  // (not awaited again once the board is lost: the loop ticks on so that the supervisor holds).
  bool timed_out = false;
  const device::DeviceStatus read = board_ != nullptr && params_.lockstep && !board_down_
                                        ? ReadBoardAnswer(timed_out)
                                        : device_.ReadSensors(sensors_);
  if (board_ != nullptr) ReportRefusedFrames(tick, events);
  if (read == device::DeviceStatus::kOk) {
    sample_read_ns_ = now_ns_();
    if (board_down_) {
      if (DeviceEvent* e = events.Add(DeviceEvent::Kind::kLinkBack, tick))
        std::snprintf(e->detail, sizeof e->detail, "the board answers again after %llu ticks without a frame",
                      static_cast<unsigned long long>(ticks_without_sample_));
    }
    board_down_ = false;
    ticks_without_sample_ = 0;
    return written;
  }
  // No new sample this tick: the last one is published again (a frame lost, refused or late;
  // in real time also the board's and this loop's clocks, which are not locked).
  ++samples_missed_total_;
  ++ticks_without_sample_;
  const bool lost = timed_out || ticks_without_sample_ >= params_.lost_after_ticks;
  if (board_ != nullptr && lost && !board_down_) {
    board_down_ = true;
    device_lost_ = true;
    if (DeviceEvent* e = events.Add(DeviceEvent::Kind::kLinkLost, tick))
      std::snprintf(e->detail, sizeof e->detail, "board %s: no intact sensor frame for %llu ticks (%s; %s%s)",
                    params_.address.c_str(), static_cast<unsigned long long>(ticks_without_sample_),
                    device::ToString(read), LastOutOfRange().c_str(),
                    board_->counters().Describe().c_str());
  }
  return written;
}

device::DeviceStatus DeviceLink::ReadBoardAnswer(bool& timed_out) {
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
  const std::int64_t end_ns = now_ns_() + static_cast<std::int64_t>(params_.answer_timeout_s * 1e9);
  for (;;) {
    const double left_s = static_cast<double>(end_ns - now_ns_()) * 1e-9;
    if (left_s <= 0.0 || !board_->WaitForData(left_s)) {
      timed_out = true;
      return device_.ReadSensors(sensors_);
    }
    const device::DeviceStatus read = device_.ReadSensors(sensors_);
    if (read != device::DeviceStatus::kNoNewData || answers() != before) return read;
  }
}

void DeviceLink::ReportRefusedFrames(std::uint64_t tick, DeviceEvents& events) {
  // The first datagram of each refusing verdict is reported with its cause; every one is
  // counted (the end's log line, plant.json "board_link").
  const device::BoardLinkCounters& c = board_->counters();
  for (std::size_t v = 1; v < device::kFrameVerdictCount; ++v) {
    if (c.frames[v] == 0 || link_reported_.frames[v] != 0) continue;
    const auto verdict = static_cast<device::FrameVerdict>(v);
    if (DeviceEvent* e = events.Add(DeviceEvent::Kind::kFrameRefused, tick))
      std::snprintf(e->detail, sizeof e->detail, "a datagram from the board refused: %s%s%s%s",
                    device::ToString(verdict), verdict == device::FrameVerdict::kOutOfRange ? " (" : "",
                    verdict == device::FrameVerdict::kOutOfRange ? LastOutOfRange().c_str() : "",
                    verdict == device::FrameVerdict::kOutOfRange ? ")" : "");
  }
  link_reported_ = c;
}

std::string DeviceLink::LastOutOfRange() const {
  const int channel = board_->decoder().last_out_of_range_channel();
  if (channel < 0) return "";
  char text[96];
  std::snprintf(text, sizeof text, "%s = %.4g out of its range; ", device::BoardChannelName(channel).c_str(),
                board_->decoder().last_out_of_range_value_si());
  return text;
}

void DeviceLink::JudgeSafety(std::uint64_t tick, DeviceEvents& events) {
  const device::DeviceSafety& s = sensors_.safety;
  if (!s.estop_latched) {
    if (estop_reported_) events.Add(DeviceEvent::Kind::kEstopReleased, tick);
    estop_reported_ = false;
    estop_reset_asked_ = false;
    return;
  }
  if (!s.valves_safe) ++estop_unsafe_ticks_;  // the device's own word; never expected
  if (estop_reset_asked_ && s.reset_refused) {
    // The supervisor left HOLD on the same reset: it holds again on this report.
    estop_reset_asked_ = false;
    if (DeviceEvent* e = events.Add(DeviceEvent::Kind::kEstopResetRefused, tick))
      std::snprintf(e->detail, sizeof e->detail, "e-stop reset refused by the rig: %s",
                    s.estop_loop_open ? "the e-stop loop is still open: close it, then reset"
                                      : "the e-stop is still asked");
  }
  if (estop_reported_) return;
  estop_reported_ = true;
  // The sample that shows the latch first: its board time (the tick the input was sampled)
  // and whether every valve output was already at its safe value in that same tick.
  if (DeviceEvent* e = events.Add(DeviceEvent::Kind::kEstopLatched, tick))
    std::snprintf(e->detail, sizeof e->detail, "e-stop: %s; valves %s at device tick %.0f",
                  EstopSource(s), s.valves_safe ? "all at their safe value" : "NOT all safe",
                  sensors_.device_time_s * 1e3);
}

void DeviceLink::LatchOperatorEstop(std::uint32_t sequence, std::uint64_t tick, DeviceEvents& events) {
  if (operator_estop_sequence_ == sequence) return;  // the same command by the other path
  operator_estop_sequence_ = sequence;
  device_.LatchEstop();  // the valves to their safe values from this tick's write on
  if (DeviceEvent* e = events.Add(DeviceEvent::Kind::kOperatorEstop, tick))
    std::snprintf(e->detail, sizeof e->detail, "e-stop: operator command #%u: every valve to its "
                  "safe value from tick %llu", static_cast<unsigned>(sequence),
                  static_cast<unsigned long long>(tick));
}

bool DeviceLink::RequestEstopReset() {
  if (!sensors_.safety.estop_latched) return false;
  device_.RequestEstopReset();  // the rig refuses while its loop is open
  estop_reset_asked_ = true;
  operator_estop_sequence_ = 0;
  return true;
}

std::string DeviceLink::DescribeEnd() const {
  std::string text = fmt::format(
      "control round trip (sample read from the device -> the command computed from it "
      "written): median {:.3f} ms, p99 {:.3f} ms, max {:.3f} ms over {} ticks; ticks without a "
      "new sample {}", round_trip_.Quantile_s(0.5) * 1e3, round_trip_.Quantile_s(0.99) * 1e3,
      round_trip_.max_s() * 1e3, round_trip_.count(), samples_missed_total_);
  if (board_ != nullptr) {
    text += fmt::format("; board link: received {}; send errors {}, receive errors {}; commands "
                        "clamped {}, non-finite {}", board_->counters().Describe(),
                        board_->send_errors(), board_->receive_errors(),
                        board_->encoder().clamped_values(), board_->encoder().non_finite_values());
  }
  return text;
}

}  // namespace hexa::plant_sim
