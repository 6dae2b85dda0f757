// The UDP sockets bound in this network namespace, read from /proc/net/udp and /proc/net/udp6
// (no socket of this process is opened to find them), and the process that holds one.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace hexa::deploy {

struct BoundUdpSocket {
  std::string local_address;  // as /proc/net/udp writes it: hex, 8 digits (IPv4) or 32 (IPv6)
  int port = 0;
  std::uint64_t inode = 0;
};

std::vector<BoundUdpSocket> BoundUdpSockets();

// Whether a socket has bound 127.0.0.1:`port`.
bool UdpLoopbackPortBound(int port);

// The process holding the socket with this inode, read from /proc/<pid>/fd: its name as
// "hexa_leg_ctrl (pid 1234)" ("" and pid 0 when no readable process holds it).
struct SocketHolder {
  std::string name;
  int pid = 0;
};
SocketHolder SocketOwner(std::uint64_t inode);

// The value of a process's `--domain N` argument (/proc/<pid>/cmdline), or -1 when it has
// none or it cannot be read.
int DomainArgumentOf(int pid);

}  // namespace hexa::deploy
