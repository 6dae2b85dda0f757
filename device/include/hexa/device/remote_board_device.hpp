// The remote I/O board as a Device (device.hpp): one UDP datagram per tick each way
// (docs/board_protocol.md). Non-blocking: ReadSensors drains what has arrived and keeps the
// newest intact frame; WriteValves sends one command frame. Every refused datagram is counted
// by its reason (BoardLinkCounters). The board keeps the rig safe by itself when the host
// falls silent (its watchdog); the host's judgement of a silent board belongs to the node.
#pragma once

#include <array>
#include <cstdint>
#include <string>

#include "hexa/core/board_calibration.hpp"
#include "hexa/device/board_codec.hpp"
#include "hexa/device/device.hpp"
#include "hexa/device/udp_socket.hpp"

namespace hexa::device {

struct RemoteBoardDeviceConfig {
  std::string board_host = "127.0.0.1";  // dotted IPv4 address of the board
  std::uint16_t board_port = 0;
  std::string local_host = "0.0.0.0";    // where the host listens for sensor frames
  std::uint16_t local_port = 0;          // 0: any free port
  BoardCalibration calibration;          // the rig file's `board` block
  double valve_null_v = 5.0;             // valve.null_voltage_v: for a non-finite command
  int estop_reset_frames = 3;            // commands that carry one reset request (losses)

  // Throws std::invalid_argument naming the field, the value and the limit.
  void Validate() const;
};

class RemoteBoardDevice final : public Device {
 public:
  explicit RemoteBoardDevice(const RemoteBoardDeviceConfig& config);  // validates
  ~RemoteBoardDevice() override { Close(); }

  bool Configure(std::string& error) override;
  DeviceStatus ReadSensors(DeviceSensors& out) override;
  DeviceStatus WriteValves(const LegArray<double>& valve_v) override;
  DeviceStatus WriteSafeState() override;
  void LatchEstop() override { estop_requested_ = true; }
  void RequestEstopReset() override;
  void Close() override;

  // Waits until a datagram is readable (lockstep with an emulator in step mode).
  bool WaitForData(double timeout_s) const { return socket_.WaitReadable(timeout_s); }
  sockaddr_in local_address() const { return socket_.local_address(); }
  const BoardLinkCounters& counters() const { return decoder_.counters(); }
  const BoardSensorDecoder& decoder() const { return decoder_; }
  const BoardCommandEncoder& encoder() const { return encoder_; }
  std::uint64_t send_errors() const { return send_errors_; }
  std::uint64_t receive_errors() const { return receive_errors_; }

 private:
  DeviceStatus Send(const LegArray<double>& valve_v, std::uint16_t flags);

  RemoteBoardDeviceConfig config_;
  sockaddr_in board_address_{};
  UdpSocket socket_;
  BoardSensorDecoder decoder_;
  BoardCommandEncoder encoder_;
  bool configured_ = false;
  bool estop_requested_ = false;
  int reset_frames_left_ = 0;
  bool reset_needs_gap_ = false;  // the last frame carried the reset bit: one without it first
  bool last_reset_bit_ = false;
  std::uint64_t send_errors_ = 0;
  std::uint64_t receive_errors_ = 0;
  std::array<std::uint8_t, HB_MAX_FRAME_SIZE + 1> rx_{};  // one byte more: oversize is seen
  std::array<std::uint8_t, HB_COMMAND_FRAME_SIZE> tx_{};
};

}  // namespace hexa::device
