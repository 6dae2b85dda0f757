#include "netns_lab.hpp"

#include <signal.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <iterator>
#include <regex>
#include <sstream>
#include <stdexcept>
#include <vector>

namespace hexa::deploy {
namespace {

std::string Ip() { return access("/usr/sbin/ip", X_OK) == 0 ? "/usr/sbin/ip" : "/sbin/ip"; }
std::string Nft() { return access("/usr/sbin/nft", X_OK) == 0 ? "/usr/sbin/nft" : "/sbin/nft"; }

long long CounterOf(const std::string& listing, const std::string& comment) {
  // "... counter packets 12 bytes 3456 [log group 5 queue-threshold 1 ]drop comment "loss""
  // (nft list output; the "input" rule has no verdict)
  const std::regex re("counter packets ([0-9]+) bytes [0-9]+ (?:log group [0-9]+ queue-threshold [0-9]+ )?(?:drop )?comment \"" +
                      comment + "\"");
  std::smatch m;
  return std::regex_search(listing, m, re) ? std::stoll(m[1]) : -1;
}

}  // namespace

bool RunShell(const std::string& command, std::string* output) {
  FILE* p = popen((command + " 2>&1").c_str(), "r");
  if (p == nullptr) return false;
  std::string text;
  char buf[512];
  while (std::fgets(buf, sizeof buf, p) != nullptr) text += buf;
  const int rc = pclose(p);
  if (output != nullptr) *output = text;
  return rc == 0;
}

std::unique_ptr<NetnsLab> NetnsLab::Create(const std::string& tag,
                                           const std::vector<std::string>& host_names,
                                           const std::string& subnet, std::string& error) {
  if (geteuid() != 0) {
    error = "needs root to create network namespaces";
    return nullptr;
  }
  if (host_names.empty() || host_names.size() > 9) {
    error = "a lab has 1..9 hosts";
    return nullptr;
  }
  CleanStale(tag);
  std::unique_ptr<NetnsLab> lab(new NetnsLab());
  lab->tag_ = tag;
  const std::string pid = std::to_string(getpid());
  // Interface names are at most 15 characters: a short tag, one digit, the pid.
  const std::string short_tag = tag.substr(0, 3);
  lab->switch_ns_ = tag + "-sw-" + pid;
  lab->bridge_ = short_tag + "b" + pid;
  const std::string ip = Ip();
  std::string out;
  auto run = [&](const std::string& cmd) {
    if (RunShell(cmd, &out)) return true;
    error = "'" + cmd + "' failed: " + out;
    return false;
  };
  if (!run(ip + " netns add " + lab->switch_ns_)) return nullptr;
  lab->namespaces_.push_back(lab->switch_ns_);
  if (!run(ip + " -n " + lab->switch_ns_ + " link set lo up") ||
      !run(ip + " -n " + lab->switch_ns_ + " link add " + lab->bridge_ + " type bridge") ||
      !run(ip + " -n " + lab->switch_ns_ + " link set " + lab->bridge_ + " up"))
    return nullptr;
  for (std::size_t i = 0; i < host_names.size(); ++i) {
    LabHost h;
    h.name = host_names[i];
    h.ns = tag + "-" + h.name + "-" + pid;
    h.veth = short_tag + "h" + std::to_string(i) + pid;
    h.port = short_tag + "s" + std::to_string(i) + pid;
    h.address = subnet + "." + std::to_string(i + 1) + "/24";
    if (!run(ip + " netns add " + h.ns)) return nullptr;
    lab->namespaces_.push_back(h.ns);
    if (!run(ip + " link add " + h.veth + " netns " + h.ns + " type veth peer name " + h.port +
             " netns " + lab->switch_ns_) ||
        !run(ip + " -n " + h.ns + " addr add " + h.address + " dev " + h.veth) ||
        !run(ip + " -n " + h.ns + " link set " + h.veth + " up") ||
        !run(ip + " -n " + h.ns + " link set lo up") ||
        !run(ip + " -n " + lab->switch_ns_ + " link set " + h.port + " master " + lab->bridge_) ||
        !run(ip + " -n " + lab->switch_ns_ + " link set " + h.port + " up"))
      return nullptr;
    lab->hosts_.push_back(h);
  }
  return lab;
}

NetnsLab::~NetnsLab() {
  for (auto it = namespaces_.rbegin(); it != namespaces_.rend(); ++it)
    RunShell(Ip() + " netns del " + *it);  // deletes its veth ends and the bridge with it
}

const LabHost& NetnsLab::host(const std::string& name) const {
  for (const auto& h : hosts_)
    if (h.name == name) return h;
  throw std::invalid_argument("no lab host '" + name + "'");
}

std::vector<std::string> NetnsLab::InHost(const std::string& host,
                                          const std::vector<std::string>& argv) const {
  std::vector<std::string> out{Ip(), "netns", "exec", this->host(host).ns};
  out.insert(out.end(), argv.begin(), argv.end());
  return out;
}

bool NetnsLab::SetInputLoss(const std::string& host, int percent, std::string& error, const std::string& match,
                            int log_group) {
  const LabHost& h = this->host(host);
  const std::string nft = Ip() + " netns exec " + h.ns + " " + Nft();
  std::string out;
  RunShell(nft + " delete table inet hexa_lab", &out);  // absent is fine
  if (percent <= 0) return true;
  if (percent > 100) {
    error = "loss percent must be 0..100";
    return false;
  }
  if (log_group < 0 || log_group > 65535) {
    error = "nflog group must be 0..65535";
    return false;
  }
  // queue-threshold 1: each dropped packet is delivered at once, not batched for up to 1 s.
  const std::string log =
      log_group > 0 ? " log group " + std::to_string(log_group) + " queue-threshold 1" : std::string();
  for (const std::string& cmd :
       {nft + " add table inet hexa_lab",
        nft + " add chain inet hexa_lab input '{ type filter hook input priority 0; policy accept; }'",
        nft + " add rule inet hexa_lab input iifname '\"" + h.veth + "\"' " + match +
            " counter comment '\"input\"'",
        nft + " add rule inet hexa_lab input iifname '\"" + h.veth + "\"' " + match +
            " numgen random mod 100 '<' " + std::to_string(percent) + " counter" + log + " drop comment '\"loss\"'"}) {
    if (!RunShell(cmd, &out)) {
      error = "nft (input loss on " + h.ns + ") failed: " + cmd + ": " + out;
      return false;
    }
  }
  return true;
}

long long NetnsLab::LossTableCounter(const std::string& host, const std::string& comment) const {
  const LabHost& h = this->host(host);
  std::string out;
  if (!RunShell(Ip() + " netns exec " + h.ns + " " + Nft() + " list table inet hexa_lab", &out))
    return -1;
  return CounterOf(out, comment);
}

long long NetnsLab::DroppedInput(const std::string& host) const { return LossTableCounter(host, "loss"); }

long long NetnsLab::InputPackets(const std::string& host) const { return LossTableCounter(host, "input"); }

long long NetnsLab::UdpReceiveBufferErrors(const std::string& host) const {
  const LabHost& h = this->host(host);
  std::string out;
  if (!RunShell(Ip() + " netns exec " + h.ns + " cat /proc/net/snmp", &out)) return -1;
  // Two "Udp:" lines: the field names, then the values.
  std::istringstream in(out);
  std::vector<std::string> names;
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("Udp: ", 0) != 0) continue;
    std::istringstream words(line.substr(5));
    std::vector<std::string> w{std::istream_iterator<std::string>(words), std::istream_iterator<std::string>()};
    if (names.empty()) {
      names = w;
      continue;
    }
    for (std::size_t i = 0; i < names.size() && i < w.size(); ++i)
      if (names[i] == "RcvbufErrors") return std::stoll(w[i]);
  }
  return -1;
}

bool NetnsLab::Partition(const std::string& host, std::string& error) {
  const LabHost& h = this->host(host);
  const std::string nft = Ip() + " netns exec " + switch_ns_ + " " + Nft();
  const std::string table = "hexa_lab_" + h.port;
  std::string out;
  for (const std::string& cmd :
       {nft + " add table bridge " + table,
        nft + " add chain bridge " + table + " forward '{ type filter hook forward priority 0; policy accept; }'",
        nft + " add rule bridge " + table + " forward iifname '\"" + h.port +
            "\"' counter drop comment '\"partition_in\"'",
        nft + " add rule bridge " + table + " forward oifname '\"" + h.port +
            "\"' counter drop comment '\"partition_out\"'"}) {
    if (!RunShell(cmd, &out)) {
      error = "nft (partition of " + h.name + ") failed: " + cmd + ": " + out;
      return false;
    }
  }
  return true;
}

long long NetnsLab::DroppedByPartition(const std::string& host) const {
  const LabHost& h = this->host(host);
  std::string out;
  if (!RunShell(Ip() + " netns exec " + switch_ns_ + " " + Nft() + " list table bridge hexa_lab_" +
                    h.port,
                &out))
    return -1;
  const long long a = CounterOf(out, "partition_in"), b = CounterOf(out, "partition_out");
  return a < 0 || b < 0 ? -1 : a + b;
}

bool NetnsLab::Heal(const std::string& host, std::string& error) {
  const LabHost& h = this->host(host);
  std::string out;
  if (!RunShell(Ip() + " netns exec " + switch_ns_ + " " + Nft() + " delete table bridge hexa_lab_" +
                    h.port,
                &out)) {
    error = "nft (heal of " + h.name + ") failed: " + out;
    return false;
  }
  return true;
}

void NetnsLab::CleanStale(const std::string& tag) {
  std::string out;
  if (!RunShell(Ip() + " netns list", &out)) return;
  const std::regex re("^(" + tag + "-[A-Za-z0-9-]*-([0-9]+))\\b");
  std::istringstream lines(out);
  for (std::string line; std::getline(lines, line);) {
    std::smatch m;
    if (!std::regex_search(line, m, re)) continue;
    const pid_t pid = static_cast<pid_t>(std::stol(m[2]));
    if (kill(pid, 0) == 0 || errno != ESRCH) continue;  // still running (or not ours to judge)
    RunShell(Ip() + " netns del " + m[1].str());
  }
}

}  // namespace hexa::deploy
