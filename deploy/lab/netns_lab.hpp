// A network of hosts on one machine, for tests and benchmarks of networked deployments
// (docs/deployment.md): one network namespace per host, joined through veth pairs to a
// bridge in a "switch" namespace, on a private subnet. Nothing is routed anywhere else: the
// namespaces have no other interface and no default route. Every name carries a tag and the
// creating process's pid, so that several labs (other engineers, parallel tests) coexist;
// the destructor deletes every namespace the lab made (veth pairs and bridge go with them),
// and CleanStale() removes what a killed process left behind.
//
// Faults with nftables, only inside the lab's own namespaces:
//   - input loss on one host: `numgen random mod 100 < P` drop on that host's input
//     (dropping on output has no effect: Cyclone retries the send, docs/platform_notes.md);
//   - a partition of one host: its bridge port drops everything in both directions
//     (nftables bridge family in the switch namespace), healed by deleting the rule.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace hexa::deploy {

struct LabHost {
  std::string name;     // as in the deployment file
  std::string ns;       // network namespace
  std::string veth;     // the host's interface (inside ns)
  std::string port;     // the switch-side end (inside the switch namespace)
  std::string address;  // "10.15.0.3/24"
};

class NetnsLab {
 public:
  // Creates the lab; nullptr + error when namespaces cannot be made (not root, ...).
  // `subnet` is the first three octets ("10.15.0"); host i gets .i+1/24.
  static std::unique_ptr<NetnsLab> Create(const std::string& tag,
                                          const std::vector<std::string>& host_names,
                                          const std::string& subnet, std::string& error);
  ~NetnsLab();
  NetnsLab(const NetnsLab&) = delete;
  NetnsLab& operator=(const NetnsLab&) = delete;

  const std::vector<LabHost>& hosts() const { return hosts_; }
  const LabHost& host(const std::string& name) const;
  const std::string& switch_ns() const { return switch_ns_; }

  // argv prefixed with `ip netns exec <ns of host>`.
  std::vector<std::string> InHost(const std::string& host, const std::vector<std::string>& argv) const;

  // Drops `percent` % of the packets arriving at `host` (0 removes the rule); with `match`
  // (an nftables expression, e.g. "udp dport { 7411, 7413 }") only of the packets it matches.
  // With `log_group` > 0 every dropped packet is also sent to that nflog group (one netlink
  // message per packet), where `tcpdump -i nflog:<group>` inside the host's namespace can
  // capture it: the dropped datagrams themselves, for attributing them to writers.
  bool SetInputLoss(const std::string& host, int percent, std::string& error, const std::string& match = "",
                    int log_group = 0);
  // Packets dropped so far by the loss rule of `host` (its nftables counter), -1 on error.
  long long DroppedInput(const std::string& host) const;
  // Packets the loss rule of `host` saw so far (dropped or not; its nftables counter), -1 on
  // error: DroppedInput / InputPackets is the loss rate the link really had.
  long long InputPackets(const std::string& host) const;
  // UDP datagrams the kernel of `host`'s namespace dropped because a socket's receive buffer
  // was full (/proc/net/snmp Udp RcvbufErrors, for the whole namespace), -1 on error: loss on
  // the host itself (a receiver too slow), not on its link.
  long long UdpReceiveBufferErrors(const std::string& host) const;
  // Cuts `host` off the bridge in both directions / restores it.
  bool Partition(const std::string& host, std::string& error);
  bool Heal(const std::string& host, std::string& error);
  // Packets dropped by the partition rule so far, -1 on error.
  long long DroppedByPartition(const std::string& host) const;

  // Deletes namespaces "<tag>-*-<pid>" whose pid no longer runs.
  static void CleanStale(const std::string& tag);

 private:
  // The packet count of the rule with `comment` in `host`'s loss table, -1 on error.
  long long LossTableCounter(const std::string& host, const std::string& comment) const;
  NetnsLab() = default;
  std::string tag_;
  std::string switch_ns_;
  std::string bridge_;
  std::vector<LabHost> hosts_;
  std::vector<std::string> namespaces_;  // every namespace to delete
};

// Runs a shell command; true on exit status 0. Output discarded unless `output` is given.
bool RunShell(const std::string& command, std::string* output = nullptr);

}  // namespace hexa::deploy
