// What `hexa_deploy generate` writes for a deployment (docs/deployment.md):
//
//   OUT/hosts/<host>/<config_dir>/cyclonedds.xml       DDS pinned to the host's DDS interface,
//                                                     unicast discovery to every host, and
//                                                     the Security section when secured
//   OUT/hosts/<host>/<config_dir>/deployment.textproto the description itself
//   OUT/hosts/<host>/lib/systemd/system/hexa-*.service one unit per process, and hexa.target
//   OUT/hosts/<host>/etc/udev/rules.d/60-hexa-cpu-latency.rules
//                                                     real time, hosts with a plant, leg or
//                                                     supervisor: the service user may hold
//                                                     the CPU wake-up latency limit
//   OUT/security-src/governance.xml, permissions/<node>.xml, identities.txt
//                                                     (deploy/make_security.sh signs them)
#pragma once

#include <ctime>
#include <string>
#include <vector>

#include "deployment.hpp"
#include "session_layout.hpp"

namespace hexa::deploy {

// The session's layout options as this deployment runs it (deploy/session): the same
// processes, role arguments, reader counts, priorities and recorder QoS as hexa_session's.
// No CPUs: each process's `cpu` is the deployment's.
session::SessionOptions SessionOptionsOf(const deployment::Deployment& d);

// Paths as a process on the host sees them.
struct HostPaths {
  std::string config_dir;  // where cyclonedds.xml and security/ are
};

// The Cyclone DDS configuration of one host. Security paths use ${HEXA_IDENTITY} (Cyclone
// expands environment variables in configuration values); each unit sets it.
std::string CycloneXml(const deployment::Deployment& d, const deployment::Host& host,
                       const HostPaths& paths);

// DDS Security documents (unsigned XML; make_security.sh signs them with the project CA).
std::string GovernanceXml(const deployment::Deployment& d);
std::string PermissionsXml(const deployment::Deployment& d, const std::string& node,
                           deployment::Role role, int leg, std::time_t now);

// The command line of a process (argv), as its unit runs it.
std::vector<std::string> CommandLine(const deployment::Deployment& d, const ProcessPlan& plan,
                                     const HostPaths& paths);
// The systemd unit of a process, and the per-host target that groups them.
std::string UnitFileText(const deployment::Deployment& d, const ProcessPlan& plan,
                     const HostPaths& paths);
std::string TargetFileText(const deployment::Deployment& d, const deployment::Host& host);
// The udev rule that gives group hexa write access to /dev/cpu_dma_latency.
inline constexpr const char* kCpuLatencyUdevRuleFile = "60-hexa-cpu-latency.rules";
std::string CpuLatencyUdevRule(const deployment::Deployment& d);

struct GenerateOptions {
  // Paths inside the generated files point into OUT/hosts/<host>/ instead of the on-host
  // paths (config_dir): for tests and for trying a deployment on one machine in network
  // namespaces. bin_dir, rig_file and record_dir are used as given.
  bool in_place = false;
  std::time_t now = 0;  // permissions validity starts here (0 = the current time)
};

struct GenerateResult {
  bool ok = false;
  std::string error;
  std::vector<std::string> files;  // every file written
};

GenerateResult Generate(const deployment::Deployment& d, const std::string& source_text,
                        const std::string& out_dir, const GenerateOptions& options);

// Splits a systemd command line (ExecStart=) the way systemd does for what the generator
// writes: words separated by blanks, single or double quotes, "$$" -> "$", "%%" -> "%".
std::vector<std::string> SplitCommandLine(const std::string& line);
// Joins argv into an ExecStart= value (quotes words with blanks, escapes $ and %).
std::string JoinCommandLine(const std::vector<std::string>& argv);

}  // namespace hexa::deploy
