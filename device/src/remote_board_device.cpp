// The remote I/O board as a Device (remote_board_device.hpp).
#include "hexa/device/remote_board_device.hpp"

#include <cmath>
#include <cstring>
#include <stdexcept>

namespace hexa::device {

void RemoteBoardDeviceConfig::Validate() const {
  auto fail = [](const std::string& field, const std::string& what, const std::string& value,
                 const std::string& limit) {
    throw std::invalid_argument(field + ": " + what + " (value " + value + ", limit " + limit + ")");
  };
  if (!ParseIpv4(board_host, board_port)) {
    fail("board_host", "not a dotted IPv4 address", "\"" + board_host + "\"", "a.b.c.d");
  }
  if (board_port == 0) fail("board_port", "the board's port is required", "0", "1..65535");
  if (!ParseIpv4(local_host, local_port)) {
    fail("local_host", "not a dotted IPv4 address", "\"" + local_host + "\"", "a.b.c.d");
  }
  if (!std::isfinite(valve_null_v)) fail("valve_null_v", "must be finite", FormatParam(valve_null_v), "finite");
  if (estop_reset_frames < 1 || estop_reset_frames > 100) {
    fail("estop_reset_frames", "out of range", std::to_string(estop_reset_frames), "[1, 100]");
  }
  // The channels' ranges are judged against the rig by the rig file's loader
  // (CheckBoardCalibration); what the link itself needs is checked here.
  std::vector<ParamIssue> issues;
  ParamChecker c(issues);
  c.IntInClosed("board.adc_bits", calibration.adc_bits, 8, 16, "ADC resolution");
  c.IntInClosed("board.dac_bits", calibration.dac_bits, 8, 16, "DAC resolution");
  c.InClosed("board.watchdog_timeout_s", calibration.watchdog_timeout_s, kBoardWatchdogMin_s, kBoardWatchdogMax_s,
             "board watchdog time");
  if (!issues.empty()) fail(issues[0].field, issues[0].message, issues[0].value, issues[0].limit);
}

RemoteBoardDevice::RemoteBoardDevice(const RemoteBoardDeviceConfig& config)
    : config_((config.Validate(), config)),
      decoder_(config.calibration),
      encoder_(config.calibration, config.valve_null_v) {}

bool RemoteBoardDevice::Configure(std::string& error) {
  Close();
  board_address_ = *ParseIpv4(config_.board_host, config_.board_port);
  if (!socket_.Open(*ParseIpv4(config_.local_host, config_.local_port), error)) return false;
  configured_ = true;
  return true;
}

DeviceStatus RemoteBoardDevice::ReadSensors(DeviceSensors& out) {
  if (!configured_) return DeviceStatus::kNotConfigured;
  bool fresh = false, imu_fresh = false;
  for (;;) {
    sockaddr_in from{};
    int err = 0;
    const long n = socket_.Receive(rx_, from, err);
    if (n < 0) {
      if (err != 0) {
        ++receive_errors_;
        return fresh ? DeviceStatus::kOk : DeviceStatus::kIoError;
      }
      break;
    }
    if (!SameAddress(from, board_address_)) {
      decoder_.Count(FrameVerdict::kUnknownSender);
      continue;
    }
    if (static_cast<std::size_t>(n) > HB_MAX_FRAME_SIZE) {
      decoder_.Count(FrameVerdict::kBadSize);
      continue;
    }
    const std::span<const std::uint8_t> datagram(rx_.data(), static_cast<std::size_t>(n));
    if (decoder_.Decode(datagram, out) == FrameVerdict::kOk) {
      fresh = true;
      imu_fresh = imu_fresh || out.imu.fresh;
    }
  }
  // Of several frames read at once the newest is kept; an IMU sample renewed in an older one
  // is still new to the caller.
  if (fresh) out.imu.fresh = imu_fresh;
  return fresh ? DeviceStatus::kOk : DeviceStatus::kNoNewData;
}

void RemoteBoardDevice::RequestEstopReset() {
  estop_requested_ = false;
  reset_frames_left_ = config_.estop_reset_frames;
  reset_needs_gap_ = last_reset_bit_;
}

DeviceStatus RemoteBoardDevice::Send(const LegArray<double>& valve_v, std::uint16_t flags) {
  if (!configured_) return DeviceStatus::kNotConfigured;
  if (estop_requested_) flags |= HB_CMD_ESTOP;
  // The board resets on the reset bit's 0 -> 1 edge: one request is a run of frames with it
  // (so that a lost datagram does not lose the request), then frames without it; a request
  // during a run starts after one frame without it.
  if (reset_needs_gap_) {
    reset_needs_gap_ = false;
  } else if (reset_frames_left_ > 0) {
    flags |= HB_CMD_RESET_ESTOP;
    --reset_frames_left_;
  }
  last_reset_bit_ = (flags & HB_CMD_RESET_ESTOP) != 0;
  const std::size_t n = encoder_.Encode(valve_v, flags, tx_);
  int err = 0;
  if (!socket_.Send(std::span<const std::uint8_t>(tx_.data(), n), board_address_, err)) {
    ++send_errors_;
    return DeviceStatus::kIoError;
  }
  return DeviceStatus::kOk;
}

DeviceStatus RemoteBoardDevice::WriteValves(const LegArray<double>& valve_v) { return Send(valve_v, 0); }

DeviceStatus RemoteBoardDevice::WriteSafeState() {
  LegArray<double> null_v;
  null_v.fill(config_.valve_null_v);
  return Send(null_v, HB_CMD_SAFE);
}

void RemoteBoardDevice::Close() {
  if (!configured_) return;
  WriteSafeState();  // best effort; the board's watchdog covers a lost datagram
  socket_.Close();
  configured_ = false;
}

}  // namespace hexa::device
