// The receiving side of the external motion stream (docs/motion_stream.md "Motion stream"): a
// non-blocking UDP socket that drains the datagrams waiting at each supervisor tick, decodes
// them (core/motion_stream.hpp) and hands the valid ones to a MotionStream; refusals are
// counted in it by reason. No allocation after construction.
//
//   MotionStreamReceiver receiver({"127.0.0.1", 47800}, config.decode);
//   ... every tick:
//   const std::size_t n = receiver.Receive(stream);
//   stream.Update({time_s, receiver.packets(), n}, output);
//
// Loopback by default: a stream moves the platform, so anything that can send to the port can
// move it. Binding another address is the operator's explicit choice (docs/operate.md).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "hexa/core/motion_stream.hpp"

namespace hexa::udp {

inline constexpr std::uint16_t kDefaultStreamPort = 47800;

struct StreamEndpoint {
  std::string address = "127.0.0.1";  // IPv4 address to bind
  std::uint16_t port = kDefaultStreamPort;  // 0: any free port (tests), see port()
};

class MotionStreamReceiver {
 public:
  // Binds the socket. Throws std::runtime_error naming the address, the port and the reason.
  MotionStreamReceiver(const StreamEndpoint& endpoint, const StreamDecodeLimits& limits,
                       std::size_t max_packets_per_call = 64);
  ~MotionStreamReceiver();
  MotionStreamReceiver(const MotionStreamReceiver&) = delete;
  MotionStreamReceiver& operator=(const MotionStreamReceiver&) = delete;

  // Reads every datagram waiting (at most max_packets_per_call; the rest stay for the next
  // call). Valid packets land in packets() (arrival order); each refusal is counted in
  // `stream` (MotionStream::CountRefused). Returns the number of valid packets. Never blocks.
  std::size_t Receive(MotionStream& stream) noexcept;
  // The same, each refusal counted in `refusals` (a stream owned elsewhere: the supervisor's).
  std::size_t Receive(StreamCounters& refusals) noexcept;
  const StreamPacket* packets() const { return packets_.data(); }
  std::uint16_t port() const { return port_; }  // the bound port
  std::uint64_t datagrams() const { return datagrams_; }

 private:
  template <typename CountRefusal>
  std::size_t Drain(CountRefusal&& count_refusal) noexcept;

  int fd_ = -1;
  std::uint16_t port_ = 0;
  StreamDecodeLimits limits_;
  std::vector<StreamPacket> packets_;
  std::uint64_t datagrams_ = 0;
};

}  // namespace hexa::udp
