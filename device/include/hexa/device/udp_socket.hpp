// A non-blocking IPv4 UDP socket (RAII) for the board link and the board emulator. Errors
// name the address and the system's reason ("127.0.0.1:5005: Address already in use").
#pragma once

#include <netinet/in.h>

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>

namespace hexa::device {

// "a.b.c.d" + port -> address; nullopt if `host` is not a dotted IPv4 address.
std::optional<sockaddr_in> ParseIpv4(const std::string& host, std::uint16_t port);
std::string ToString(const sockaddr_in& address);  // "127.0.0.1:5005"
bool SameAddress(const sockaddr_in& a, const sockaddr_in& b);

class UdpSocket {
 public:
  UdpSocket() = default;
  UdpSocket(const UdpSocket&) = delete;
  UdpSocket& operator=(const UdpSocket&) = delete;
  UdpSocket(UdpSocket&& other) noexcept;
  UdpSocket& operator=(UdpSocket&& other) noexcept;
  ~UdpSocket() { Close(); }

  // Opens a non-blocking socket bound to `local` (port 0: any free one). False with `error`.
  bool Open(const sockaddr_in& local, std::string& error);
  void Close();
  bool is_open() const { return fd_ >= 0; }
  int fd() const { return fd_; }
  sockaddr_in local_address() const;  // with the port the kernel chose

  // One datagram, or -1 when none is waiting (or on an error: `error_errno` set). A datagram
  // longer than `buffer` is reported with its full length (MSG_TRUNC) so that it can be refused.
  long Receive(std::span<std::uint8_t> buffer, sockaddr_in& from, int& error_errno);
  // Sends one datagram; false on an error (`error_errno`), e.g. a full socket buffer.
  bool Send(std::span<const std::uint8_t> datagram, const sockaddr_in& to, int& error_errno);
  // Waits until a datagram is readable or `timeout_s` passed; true if readable.
  bool WaitReadable(double timeout_s) const;

 private:
  int fd_ = -1;
};

}  // namespace hexa::device
