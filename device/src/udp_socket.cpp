// A non-blocking IPv4 UDP socket (udp_socket.hpp).
#include "hexa/device/udp_socket.hpp"

#include <arpa/inet.h>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <fcntl.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

namespace hexa::device {

std::optional<sockaddr_in> ParseIpv4(const std::string& host, std::uint16_t port) {
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(port);
  if (inet_pton(AF_INET, host.c_str(), &a.sin_addr) != 1) return std::nullopt;
  return a;
}

std::string ToString(const sockaddr_in& address) {
  char text[INET_ADDRSTRLEN] = "?";
  inet_ntop(AF_INET, &address.sin_addr, text, sizeof text);
  return std::string(text) + ":" + std::to_string(ntohs(address.sin_port));
}

bool SameAddress(const sockaddr_in& a, const sockaddr_in& b) {
  return a.sin_addr.s_addr == b.sin_addr.s_addr && a.sin_port == b.sin_port;
}

UdpSocket::UdpSocket(UdpSocket&& other) noexcept : fd_(other.fd_) { other.fd_ = -1; }

UdpSocket& UdpSocket::operator=(UdpSocket&& other) noexcept {
  if (this != &other) {
    Close();
    fd_ = other.fd_;
    other.fd_ = -1;
  }
  return *this;
}

bool UdpSocket::Open(const sockaddr_in& local, std::string& error) {
  Close();
  const int fd = socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd < 0) {
    error = std::string("cannot create a UDP socket: ") + std::strerror(errno);
    return false;
  }
  if (bind(fd, reinterpret_cast<const sockaddr*>(&local), sizeof local) != 0) {
    error = "cannot bind UDP " + ToString(local) + ": " + std::strerror(errno);
    ::close(fd);
    return false;
  }
  fd_ = fd;
  return true;
}

void UdpSocket::Close() {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
}

sockaddr_in UdpSocket::local_address() const {
  sockaddr_in a{};
  socklen_t size = sizeof a;
  if (fd_ >= 0) getsockname(fd_, reinterpret_cast<sockaddr*>(&a), &size);
  return a;
}

long UdpSocket::Receive(std::span<std::uint8_t> buffer, sockaddr_in& from, int& error_errno) {
  socklen_t size = sizeof from;
  const ssize_t n = recvfrom(fd_, buffer.data(), buffer.size(), MSG_TRUNC, reinterpret_cast<sockaddr*>(&from), &size);
  if (n < 0) {
    error_errno = (errno == EAGAIN || errno == EWOULDBLOCK) ? 0 : errno;
    return -1;
  }
  error_errno = 0;
  return static_cast<long>(n);
}

bool UdpSocket::Send(std::span<const std::uint8_t> datagram, const sockaddr_in& to, int& error_errno) {
  const ssize_t n = sendto(fd_, datagram.data(), datagram.size(), 0, reinterpret_cast<const sockaddr*>(&to), sizeof to);
  error_errno = n < 0 ? errno : 0;
  return n == static_cast<ssize_t>(datagram.size());
}

bool UdpSocket::WaitReadable(double timeout_s) const {
  pollfd p{fd_, POLLIN, 0};
  const int ms = timeout_s <= 0.0 ? 0 : static_cast<int>(std::ceil(timeout_s * 1000.0));
  int r;
  do {
    r = poll(&p, 1, ms);
  } while (r < 0 && errno == EINTR);
  return r > 0 && (p.revents & POLLIN);
}

}  // namespace hexa::device
