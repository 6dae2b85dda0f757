// Deployment description (proto/deployment.proto): loading, defaults, validation, and the
// per-process plan that every generated file is derived from (docs/deployment.md).
#pragma once

#include <string>
#include <vector>

#include "deployment.pb.h"

namespace hexa::deploy {

// Defaults of the optional fields (filled in by ApplyDefaults()).
inline constexpr char kDefaultBinDir[] = "/usr/bin";
inline constexpr char kDefaultConfigDir[] = "/etc/hexa";
inline constexpr char kDefaultRecordDir[] = "/var/lib/hexa/recordings";
inline constexpr unsigned kDefaultCertificateDays = 3650;
// security.metadata_protection when unset (docs/security.md, "Governance": the payload is
// encrypted either way; what NONE saves and gives up is measured and stated there).
inline constexpr deployment::Protection kDefaultMetadataProtection = deployment::ENCRYPT;
// security.loop_metadata_protection when unset: the same as metadata_protection (ENCRYPT by
// default: security is not weakened by default). NONE on the 1 kHz loop topics is an explicit
// choice of the deployment file: it took the secured real-time loop from 0 of 8 to 3 of 5
// completed sessions on a 2-vCPU machine; what it gives up (replay of a captured sample, forged
// heartbeats / acknowledgements on those topics): docs/security.md, "Governance".
inline constexpr int kMaxDomainId = 230;

struct LoadedDeployment {
  bool ok = false;
  // One line per problem: "FILE:LINE: error: host 'legs-b' (host[2]): <what> (value X, limit Y)".
  std::vector<std::string> errors;
  deployment::Deployment deployment;  // with defaults applied (valid only when ok)
};

// Parses `path` (protobuf text format), applies defaults and validates. Never throws.
LoadedDeployment LoadDeployment(const std::string& path);
// The same for text already in memory; `name` is used in the messages.
LoadedDeployment ParseDeployment(const std::string& text, const std::string& name);

void ApplyDefaults(deployment::Deployment& d);

// One process of the deployment, with the names every generated file uses.
struct ProcessPlan {
  std::string host;       // host name
  int host_index = 0;
  int process_index = 0;
  deployment::Process process;
  std::string node;       // NodeStatus name and DDS Security identity: plant, leg3, leg3_standby
  std::string unit;       // systemd unit: hexa-plant.service, hexa-leg3-standby.service
  bool has_unit = true;   // OPERATOR: identity only
};

// In host order, then process order. Assumes a valid deployment.
std::vector<ProcessPlan> PlanProcesses(const deployment::Deployment& d);

// The node name of a process ("leg3_standby").
std::string NodeName(const deployment::Process& p);
// Certificate subject of an identity: "CN=leg3,O=HexaTaar,OU=<deployment>".
std::string SubjectOf(const deployment::Deployment& d, const std::string& node);

// "10.10.0.3/24" -> address and prefix; false when malformed.
bool ParseIpv4Cidr(const std::string& text, unsigned& address, int& prefix);
// Address part of "10.10.0.3/24".
std::string AddressOf(const std::string& cidr);

// The DDS interface of a host (assumes a valid deployment).
const deployment::Interface& DdsInterface(const deployment::Host& host);

const char* ToString(deployment::Role role);
const char* ToString(deployment::Mode mode);

}  // namespace hexa::deploy
