#include "udp_ports.hpp"

#include <dirent.h>
#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <sstream>

namespace hexa::deploy {
namespace {

void ReadTable(const char* path, std::vector<BoundUdpSocket>& out) {
  std::ifstream table(path);
  std::string line;
  std::getline(table, line);  // the header
  while (std::getline(table, line)) {
    // sl local_address rem_address st tx_queue:rx_queue tr:tm->when retrnsmt uid timeout inode
    std::istringstream fields(line);
    std::string slot, local, remote, state, queues, timer, retransmits;
    long uid = 0, timeout = 0;
    BoundUdpSocket s;
    if (!(fields >> slot >> local >> remote >> state >> queues >> timer >> retransmits >> uid >> timeout >> s.inode))
      continue;
    const auto colon = local.find(':');
    if (colon == std::string::npos) continue;
    s.local_address = local.substr(0, colon);
    s.port = static_cast<int>(std::stoul(local.substr(colon + 1), nullptr, 16));
    out.push_back(s);
  }
}

}  // namespace

std::vector<BoundUdpSocket> BoundUdpSockets() {
  std::vector<BoundUdpSocket> out;
  ReadTable("/proc/net/udp", out);
  ReadTable("/proc/net/udp6", out);
  return out;
}

bool UdpLoopbackPortBound(int port) {
  for (const auto& s : BoundUdpSockets())
    if (s.port == port && s.local_address == "0100007F") return true;
  return false;
}

SocketHolder SocketOwner(std::uint64_t inode) {
  const std::string want = "socket:[" + std::to_string(inode) + "]";
  DIR* proc = opendir("/proc");
  if (proc == nullptr) return {};
  SocketHolder owner;
  while (const dirent* p = readdir(proc)) {
    if (p->d_name[0] < '0' || p->d_name[0] > '9') continue;
    const std::string dir = std::string("/proc/") + p->d_name;
    DIR* fds = opendir((dir + "/fd").c_str());
    if (fds == nullptr) continue;
    while (const dirent* f = readdir(fds)) {
      char target[64];
      const ssize_t n = readlink((dir + "/fd/" + f->d_name).c_str(), target, sizeof target - 1);
      if (n <= 0) continue;
      target[n] = '\0';
      if (want != target) continue;
      std::string comm;
      std::getline(std::ifstream(dir + "/comm"), comm);
      owner.name = comm + " (pid " + p->d_name + ")";
      owner.pid = std::atoi(p->d_name);
      break;
    }
    closedir(fds);
    if (owner.pid != 0) break;
  }
  closedir(proc);
  return owner;
}

int DomainArgumentOf(int pid) {
  std::ifstream cmdline("/proc/" + std::to_string(pid) + "/cmdline");
  std::string argument;
  bool next_is_domain = false;
  while (std::getline(cmdline, argument, '\0')) {
    if (next_is_domain) {
      char* end = nullptr;
      const long domain = std::strtol(argument.c_str(), &end, 10);
      return end != argument.c_str() && *end == '\0' && domain >= 0 ? static_cast<int>(domain) : -1;
    }
    next_is_domain = argument == "--domain";
  }
  return -1;
}

}  // namespace hexa::deploy
