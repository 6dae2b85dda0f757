// The plant's side of the device seam, without DDS: the device's bring-up (a remote board's
// power-up e-stop latch reset with the loop closed, a first sample), one exchange per tick
// (write: the arbitrated valves; read: the next sample), and the judgement of what the device
// reports: the e-stop latch and its source, a reset refused, the board's link lost and back,
// the operator's e-stop. The node publishes the events as FaultEvents and logs them.
//
// ros2_control-style: the node calls Exchange once per tick from its control loop; the
// parameters are fixed at construction (DeviceLinkParams) and the link's state is its own.
// The clock is an argument (a function returning monotonic ns), so that tests can drive it.
// No allocation and no exception in Exchange / JudgeSafety / LatchOperatorEstop.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>

#include "hexa/device/device.hpp"
#include "hexa/device/remote_board_device.hpp"
#include "hexa.h"
#include "run_figures.hpp"

namespace hexa::plant_sim {

struct DeviceLinkParams {
  bool lockstep = true;
  // Lockstep: a command frame must be answered by a sensor frame within this (the emulator in
  // step mode); bring-up: the board must answer within this.
  double answer_timeout_s = 2.0;
  // The board has failed when no intact frame came for this many ticks in a row (lost or
  // refused frames; lockstep: also when a command is not answered within answer_timeout_s).
  std::uint64_t lost_after_ticks = 20;
  std::string address;  // "host:port" of a remote board, for messages
};

// What the link has to say after a call: each event a FaultEvent of the plant (leg 0) with
// `detail`, and a log line.
struct DeviceEvent {
  enum class Kind : std::uint8_t {
    kEstopLatched,       // FAULT_ESTOP: the device shows its latch (source in the detail)
    kEstopResetRefused,  // FAULT_ESTOP: an operator reset refused by the rig
    kOperatorEstop,      // FAULT_ESTOP: the operator's e-stop latched in the device
    kLinkLost,           // FAULT_BOARD_LINK: no intact sensor frame
    kEstopReleased,      // (log only) the latch was reset: the valves follow again
    kLinkBack,           // (log only) the board answers again
    kFrameRefused,       // (log only) the first datagram refused with a verdict (its cause)
  };
  Kind kind = Kind::kEstopLatched;
  std::uint64_t tick = 0;
  char detail[160] = {};
  bool fault() const {
    return kind != Kind::kEstopReleased && kind != Kind::kLinkBack && kind != Kind::kFrameRefused;
  }
  hexa_msg_FaultReason reason() const;
};

class DeviceEvents {
 public:
  static constexpr std::size_t kCapacity = 8;
  void Clear() { size_ = 0; }
  DeviceEvent* Add(DeviceEvent::Kind kind, std::uint64_t tick);  // nullptr when full (dropped)
  std::size_t size() const { return size_; }
  const DeviceEvent& operator[](std::size_t i) const { return events_[i]; }

 private:
  std::array<DeviceEvent, kCapacity> events_{};
  std::size_t size_ = 0;
};

class DeviceLink {
 public:
  using Clock = std::int64_t (*)();  // monotonic ns

  // `board`: the same device when it is a remote board (its link is judged), else nullptr.
  DeviceLink(device::Device& device, device::RemoteBoardDevice* board, DeviceLinkParams params,
             Clock now_ns);

  // Configures the device and reads its first sample; a board's e-stop latch is reset with
  // its loop closed. Throws naming the cause (address, port, e-stop). Returns what to log
  // ("" for the simulation).
  std::string BringUp();

  // One tick: write `valve_v`, then read the sample the device has for the next tick (a board
  // in lockstep: awaited). The status of the write (kFault: the device cannot go on). Without
  // a new sample the last one stays; a board's link is then judged for `tick`. With
  // `safe_state` (the hardware lifecycle not active) every valve is held at its safe value
  // instead of `valve_v` (Device::WriteSafeState).
  device::DeviceStatus Exchange(const LegArray<double>& valve_v, std::uint64_t tick,
                                DeviceEvents& events, bool safe_state = false);
  // The e-stop as the newest sample shows it, for `tick`.
  void JudgeSafety(std::uint64_t tick, DeviceEvents& events);
  // The operator's e-stop #`sequence`: latched in the device once per command, whichever path
  // brings it (the command itself, or the supervisor's FaultEvent about it).
  void LatchOperatorEstop(std::uint32_t sequence, std::uint64_t tick, DeviceEvents& events);
  // An operator reset: asks the device to clear its latch (the rig refuses while its loop is
  // open: JudgeSafety reports it). False, nothing asked, when nothing is latched.
  bool RequestEstopReset();

  const device::DeviceSensors& sensors() const { return sensors_; }
  bool lost() const { return device_lost_; }  // the board was lost during the run
  const DurationHistogram& round_trip() const { return round_trip_; }
  std::uint64_t samples_missed_total() const { return samples_missed_total_; }
  std::uint64_t estop_unsafe_ticks() const { return estop_unsafe_ticks_; }
  // The end-of-run log lines (round trip, missed samples, unsafe ticks, the board's counters).
  std::string DescribeEnd() const;

 private:
  // Lockstep: this command's answer from the board (timed_out: none within the timeout).
  device::DeviceStatus ReadBoardAnswer(bool& timed_out);
  void ReportRefusedFrames(std::uint64_t tick, DeviceEvents& events);  // the first of each verdict
  std::string LastOutOfRange() const;  // "leg 1 potentiometer_m = 0.3734 out of its range; " or ""

  device::Device& device_;
  device::RemoteBoardDevice* board_;
  DeviceLinkParams params_;
  Clock now_ns_;

  device::DeviceSensors sensors_{};  // the device's newest sample
  // The control round trip: a sample read from the device -> the command computed from it
  // written.
  DurationHistogram round_trip_;
  std::int64_t sample_read_ns_ = -1;  // when the newest sample was read; -1: answered already
  std::uint64_t ticks_without_sample_ = 0;
  std::uint64_t samples_missed_total_ = 0;
  bool estop_reported_ = false;
  bool estop_reset_asked_ = false;             // its refusal reported once
  std::uint32_t operator_estop_sequence_ = 0;  // the operator e-stop latched (0: none)
  std::uint64_t estop_unsafe_ticks_ = 0;       // latched, yet a valve not at its safe value
  bool board_down_ = false;                    // no frame since FAULT_BOARD_LINK
  device::BoardLinkCounters link_reported_{};  // the counters as last reported
  bool device_lost_ = false;
};

}  // namespace hexa::plant_sim
