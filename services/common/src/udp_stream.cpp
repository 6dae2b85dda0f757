// Receiving side of the external motion stream (see udp_stream.hpp).
#include "hexa/services/udp_stream.hpp"

#include <arpa/inet.h>
#include <cerrno>
#include <cstring>
#include <netinet/in.h>
#include <stdexcept>
#include <sys/socket.h>
#include <unistd.h>

namespace hexa::udp {

MotionStreamReceiver::MotionStreamReceiver(const StreamEndpoint& endpoint,
                                           const StreamDecodeLimits& limits,
                                           std::size_t max_packets_per_call)
    : limits_(limits), packets_(max_packets_per_call == 0 ? 1 : max_packets_per_call) {
  const std::string where = endpoint.address + ":" + std::to_string(endpoint.port);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(endpoint.port);
  if (inet_pton(AF_INET, endpoint.address.c_str(), &address.sin_addr) != 1) {
    throw std::runtime_error("motion stream: '" + endpoint.address +
                             "' is not an IPv4 address (e.g. 127.0.0.1)");
  }
  fd_ = socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd_ < 0) throw std::runtime_error("motion stream: socket(): " + std::string(std::strerror(errno)));
  if (bind(fd_, reinterpret_cast<const sockaddr*>(&address), sizeof(address)) != 0) {
    const std::string reason = std::strerror(errno);
    close(fd_);
    throw std::runtime_error("motion stream: cannot bind " + where + ": " + reason);
  }
  socklen_t length = sizeof(address);
  getsockname(fd_, reinterpret_cast<sockaddr*>(&address), &length);
  port_ = ntohs(address.sin_port);
}

MotionStreamReceiver::~MotionStreamReceiver() {
  if (fd_ >= 0) close(fd_);
}

template <typename CountRefusal>
std::size_t MotionStreamReceiver::Drain(CountRefusal&& count_refusal) noexcept {
  std::size_t count = 0;
  std::uint8_t buffer[256];
  for (std::size_t i = 0; i < packets_.size(); ++i) {
    // MSG_TRUNC: the datagram's real length, so that an oversized one is refused as such.
    const ssize_t n = recv(fd_, buffer, sizeof(buffer), MSG_DONTWAIT | MSG_TRUNC);
    if (n < 0) break;  // EAGAIN: drained (other errors: nothing to read either)
    ++datagrams_;
    const StreamDecodeResult result =
        DecodeStreamPacket(buffer, static_cast<std::size_t>(n), limits_, packets_[count]);
    if (result.error == StreamPacketError::kOk) {
      ++count;
    } else {
      count_refusal(result);
    }
  }
  return count;
}

std::size_t MotionStreamReceiver::Receive(MotionStream& stream) noexcept {
  return Drain([&](const StreamDecodeResult& r) { stream.CountRefused(r); });
}

std::size_t MotionStreamReceiver::Receive(StreamCounters& refusals) noexcept {
  return Drain([&](const StreamDecodeResult& r) { refusals.Count(r); });
}

}  // namespace hexa::udp
