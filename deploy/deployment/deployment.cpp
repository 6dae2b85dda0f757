#include "deployment.hpp"

#include <google/protobuf/text_format.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "hexa/config/text_format.hpp"

namespace hexa::deploy {
namespace {

namespace gp = google::protobuf;
using deployment::Deployment;
using deployment::Host;
using deployment::Process;
using deployment::Role;

// Line numbers of hosts and processes, for messages.
struct Lines {
  const gp::TextFormat::ParseInfoTree* tree = nullptr;
  int Of(const char* field, int index = -1) const {
    if (tree == nullptr) return 0;
    const auto* fd = Deployment::descriptor()->FindFieldByName(field);
    const auto loc = tree->GetLocation(fd, index);
    return loc.line >= 0 ? loc.line + 1 : 0;
  }
  int OfHost(int h) const { return Of("host", h); }
  int OfHostField(int h, const char* field, int index = -1) const {
    if (tree == nullptr) return 0;
    const auto* hf = Deployment::descriptor()->FindFieldByName("host");
    const auto* sub = tree->GetTreeForNested(hf, h);
    if (sub == nullptr) return OfHost(h);
    const auto loc = sub->GetLocation(Host::descriptor()->FindFieldByName(field), index);
    return loc.line >= 0 ? loc.line + 1 : OfHost(h);
  }
};

class Checker {
 public:
  Checker(const std::string& file, const Lines& lines) : file_(file), lines_(lines) {}
  void Error(int line, const std::string& where, const std::string& what) {
    // Line 0: a rule about the whole file (no single line to point at).
    std::string e = file_ + (line > 0 ? ":" + std::to_string(line) : std::string()) + ": error: ";
    if (!where.empty()) e += where + ": ";
    errors.push_back(e + what);
  }
  std::vector<std::string> errors;
  const std::string& file_;
  const Lines& lines_;
};

bool ValidName(const std::string& s) {
  if (s.empty() || s.size() > 32) return false;
  for (char c : s)
    if (!((c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '-')) return false;
  return s.front() != '-' && s.back() != '-';
}

bool ValidInterfaceName(const std::string& s) {
  if (s.empty() || s.size() > 15) return false;
  for (char c : s)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '-' || c == '_'))
      return false;
  return true;
}

std::string HostWhere(const Host& h, int i) {
  return "host '" + h.name() + "' (host[" + std::to_string(i) + "])";
}

std::string FormatIpv4(unsigned a) {
  char buf[20];
  std::snprintf(buf, sizeof buf, "%u.%u.%u.%u", a >> 24, (a >> 16) & 255, (a >> 8) & 255, a & 255);
  return buf;
}

// Where each role runs (host names), for the checks across hosts.
struct Census {
  std::map<int, std::vector<std::string>> primaries, standbys;  // per leg
  std::vector<std::string> plants, supervisors, recorders, operators, bridges;
};

// A host's DDS address and prefix length.
struct Dds {
  unsigned address;
  int prefix;
  int host;
};

// The deployment's own fields: name, domain, mode, security, timing, paths.
void ValidateSettings(const Deployment& d, Checker& c) {
  const Lines& L = c.lines_;
  if (!ValidName(d.name()))
    c.Error(L.Of("name"), "name",
            "'" + d.name() + "' must be 1..32 characters of a-z 0-9 '-' (not starting or "
            "ending with '-')");
  if (d.domain_id() > static_cast<unsigned>(kMaxDomainId))
    c.Error(L.Of("domain_id"), "domain_id",
            "value " + std::to_string(d.domain_id()) + " out of range (limit 0.." +
                std::to_string(kMaxDomainId) + ")");
  if (d.mode() != deployment::LOCKSTEP && d.mode() != deployment::REALTIME)
    c.Error(L.Of("mode"), "mode", "must be LOCKSTEP or REALTIME");
  if (d.security().certificate_days() > 36500)
    c.Error(L.Of("security"), "security.certificate_days",
            "value " + std::to_string(d.security().certificate_days()) + " (limit 1..36500)");
  // Discovery and liveliness must be protected: signed at least.
  if (d.security().discovery_protection() == deployment::NONE)
    c.Error(L.Of("security"), "security.discovery_protection",
            "NONE: discovery must be protected (SIGN or ENCRYPT)");
  if (d.security().liveliness_protection() == deployment::NONE)
    c.Error(L.Of("security"), "security.liveliness_protection",
            "NONE: liveliness must be protected (SIGN or ENCRYPT)");
  const auto& t = d.timing();
  auto fmt = [](double v) {
    std::ostringstream os;
    os << v;
    return os.str();
  };
  auto positive = [&](double v, const char* name, double max) {
    if (!(v >= 0.0) || !std::isfinite(v) || v > max)
      c.Error(L.Of("timing"), std::string("timing.") + name,
              "value " + fmt(v) + " s (limit 0.." + fmt(max) + ")");
  };
  positive(t.watchdog_s(), "watchdog_s", 3600);
  positive(t.lockstep_timeout_s(), "lockstep_timeout_s", 3600);
  positive(t.startup_timeout_s(), "startup_timeout_s", 3600);
  if (t.stale_ticks() > 1000)
    c.Error(L.Of("timing"), "timing.stale_ticks",
            "value " + std::to_string(t.stale_ticks()) + " (limit 0..1000)");
  if (d.mode() == deployment::LOCKSTEP && t.watchdog_s() > 0 && t.lockstep_timeout_s() > 0 &&
      t.watchdog_s() <= t.lockstep_timeout_s())
    c.Error(L.Of("timing"), "timing.watchdog_s",
            "value " + fmt(t.watchdog_s()) + " s must exceed timing.lockstep_timeout_s " +
                fmt(t.lockstep_timeout_s()) +
                " s (a lockstep tick may legitimately wait that long)");
  for (const auto* path : {&d.bin_dir(), &d.config_dir(), &d.record_dir(), &d.rig_file(),
                           &d.security().audit_dir()}) {
    if (!path->empty() && path->front() != '/')
      c.Error(0, "paths", "'" + *path + "' must be an absolute path");
  }
}

// A host's interfaces and its DDS interface: names, addresses (unique across the deployment).
void ValidateInterfaces(const Host& host, int h, Checker& c,
                        std::map<unsigned, std::string>& addresses, std::vector<Dds>& dds) {
  const Lines& L = c.lines_;
  const std::string where = HostWhere(host, h);
  std::set<std::string> iface_names;
  const deployment::Interface* dds_iface = nullptr;
  for (int i = 0; i < host.interface_size(); ++i) {
    const auto& ifc = host.interface(i);
    const int line = L.OfHostField(h, "interface", i);
    const std::string iw = where + " interface[" + std::to_string(i) + "]";
    if (ifc.name() == host.dds_interface()) dds_iface = &ifc;
    if (!ValidInterfaceName(ifc.name()))
      c.Error(line, iw, "name '" + ifc.name() + "' is not an interface name (1..15 of A-Z a-z 0-9 . - _)");
    if (!iface_names.insert(ifc.name()).second)
      c.Error(line, iw, "interface '" + ifc.name() + "' listed twice");
    unsigned a = 0;
    int prefix = 0;
    if (!ParseIpv4Cidr(ifc.address(), a, prefix)) {
      c.Error(line, iw, "address '" + ifc.address() +
                            "' is not an IPv4 address with prefix length (e.g. 10.10.0.3/24; decimal "
                            "numbers without leading zeros)");
      continue;
    }
    const unsigned mask = prefix == 0 ? 0u : ~0u << (32 - prefix);
    if (prefix < 32 && prefix > 0 && ((a & ~mask) == 0 || (a & ~mask) == (~mask)))
      c.Error(line, iw, "address '" + ifc.address() + "' is the network or broadcast address of its subnet");
    const std::string owner = host.name() + "/" + ifc.name();
    if (auto [it, fresh] = addresses.emplace(a, owner); !fresh)
      c.Error(line, iw, "address " + FormatIpv4(a) + " is also on " + it->second);
  }
  if (host.dds_interface().empty()) {
    c.Error(L.OfHost(h), where, "dds_interface is not set (the interface that carries DDS)");
  } else if (dds_iface == nullptr) {
    std::string names;
    for (const auto& n : iface_names) names += (names.empty() ? "" : ", ") + n;
    c.Error(L.OfHostField(h, "dds_interface"), where,
            "dds_interface '" + host.dds_interface() + "' is on no interface of this host (" +
                (names.empty() ? std::string("none listed") : names) + ")");
  } else {
    unsigned a = 0;
    int prefix = 0;
    if (ParseIpv4Cidr(dds_iface->address(), a, prefix)) dds.push_back({a, prefix, h});
  }
}

// A host's processes: role, leg, standby, priority, CPU, executable; counted in `census`.
void ValidateProcesses(const Host& host, int h, Checker& c, Census& census) {
  const Lines& L = c.lines_;
  const std::string where = HostWhere(host, h);
  auto& [primaries, standbys, plants, supervisors, recorders, operators, bridges] = census;
  if (host.process_size() == 0)
    c.Error(L.OfHost(h), where, "no process: a host runs at least one process");
  std::set<std::string> nodes_here;
  for (int p = 0; p < host.process_size(); ++p) {
    const Process& pr = host.process(p);
    const int line = L.OfHostField(h, "process", p);
    const std::string pw = where + " process[" + std::to_string(p) + "]";
    if (pr.role() == deployment::ROLE_UNSPECIFIED) {
      c.Error(line, pw, "role is not set (PLANT SUPERVISOR LEG RECORDER OPERATOR BRIDGE)");
      continue;
    }
    // The text format takes any number for an open enum: a role without a unit template
    // would become a unit with an empty ExecStart=.
    if (!deployment::Role_IsValid(pr.role())) {
      c.Error(line, pw, "role " + std::to_string(static_cast<int>(pr.role())) +
                            " is not one of PLANT SUPERVISOR LEG RECORDER OPERATOR BRIDGE (1..6)");
      continue;
    }
    if (pr.role() == deployment::LEG) {
      if (pr.leg() < 1 || pr.leg() > 6) {
        c.Error(line, pw, "leg " + std::to_string(pr.leg()) + " out of range (limit 1..6)");
        continue;
      }
      (pr.standby() ? standbys : primaries)[static_cast<int>(pr.leg())].push_back(host.name());
    } else {
      if (pr.leg() != 0)
        c.Error(line, pw, std::string("leg is set on a ") + ToString(pr.role()) +
                              " process (only LEG processes have a leg)");
      if (pr.standby())
        c.Error(line, pw, std::string("standby is set on a ") + ToString(pr.role()) +
                              " process (only LEG processes can be standbys)");
    }
    if (pr.role() == deployment::PLANT) plants.push_back(host.name());
    if (pr.role() == deployment::SUPERVISOR) supervisors.push_back(host.name());
    if (pr.role() == deployment::RECORDER) recorders.push_back(host.name());
    if (pr.role() == deployment::OPERATOR) operators.push_back(host.name());
    if (pr.role() == deployment::BRIDGE) bridges.push_back(host.name());
    if (pr.rt_priority() > 99)
      c.Error(line, pw, "rt_priority " + std::to_string(pr.rt_priority()) + " (limit 1..99)");
    if (pr.has_cpu() && (pr.cpu() < 0 || pr.cpu() > 1023))
      c.Error(line, pw, "cpu " + std::to_string(pr.cpu()) + " (limit 0..1023)");
    if (!pr.executable().empty() && pr.executable().front() != '/')
      c.Error(line, pw, "executable '" + pr.executable() + "' must be an absolute path");
    if (!nodes_here.insert(NodeName(pr)).second)
      c.Error(line, pw, "'" + NodeName(pr) + "' appears twice on this host");
  }
}

// One primary per leg (a standby at most, on another host), one plant and one supervisor.
void ValidateCensus(Census& census, Checker& c) {
  auto& [primaries, standbys, plants, supervisors, recorders, operators, bridges] = census;
  auto list = [](const std::vector<std::string>& v) {
    std::string s;
    for (const auto& x : v) s += (s.empty() ? "" : ", ") + x;
    return s;
  };
  for (int leg = 1; leg <= 6; ++leg) {
    const auto& pri = primaries[leg];
    if (pri.empty())
      c.Error(0, "legs", "leg " + std::to_string(leg) +
                             " is on no host (no LEG process with leg: " + std::to_string(leg) +
                             " and standby false)");
    if (pri.size() > 1)
      c.Error(0, "legs", "leg " + std::to_string(leg) + " has " + std::to_string(pri.size()) +
                             " primaries (hosts " + list(pri) +
                             "); one primary per leg, a second one is a standby");
    if (standbys[leg].size() > 1)
      c.Error(0, "legs", "leg " + std::to_string(leg) + " has " +
                             std::to_string(standbys[leg].size()) + " standbys (hosts " +
                             list(standbys[leg]) + "); at most one");
    if (pri.size() == 1 && standbys[leg].size() == 1 && pri[0] == standbys[leg][0])
      c.Error(0, "legs", "leg " + std::to_string(leg) + ": the standby runs on the primary's host '" +
                             pri[0] + "' (a standby must survive its primary's board)");
  }
  for (const auto& [role, hosts, need] :
       {std::tuple{"PLANT", &plants, true}, std::tuple{"SUPERVISOR", &supervisors, true},
        std::tuple{"RECORDER", &recorders, false}, std::tuple{"OPERATOR", &operators, false},
        std::tuple{"BRIDGE", &bridges, false}}) {
    if (need && hosts->empty()) c.Error(0, "processes", std::string("no ") + role + " process on any host");
    if (hosts->size() > 1)
      c.Error(0, "processes", std::string("more than one ") + role + " process (hosts " +
                                  list(*hosts) + "); the system has exactly " +
                                  (need ? "one" : "zero or one"));
  }
}

// The hosts' DDS addresses: one control network, and no loopback among several hosts.
void ValidateDdsNetworks(const Deployment& d, const std::vector<Dds>& dds, Checker& c) {
  const Lines& L = c.lines_;
  // Every DDS address must be on the network of every other host's DDS interface: the
  // generated configuration sends unicast to the peers' addresses with DontRoute.
  for (const Dds& a : dds) {
    for (const Dds& b : dds) {
      if (a.host == b.host) continue;
      const unsigned mask = b.prefix == 0 ? 0u : ~0u << (32 - b.prefix);
      if ((a.address & mask) != (b.address & mask)) {
        const Host& ha = d.host(a.host);
        const Host& hb = d.host(b.host);
        c.Error(L.OfHostField(a.host, "dds_interface"), HostWhere(ha, a.host),
                "DDS address " + FormatIpv4(a.address) + " (" + ha.dds_interface() +
                    ") is on no network of host '" + hb.name() + "' (its DDS interface " +
                    hb.dds_interface() + " is on " + FormatIpv4(b.address & mask) + "/" +
                    std::to_string(b.prefix) + "): hosts must share the control network");
        break;
      }
    }
  }
  if (d.host_size() > 1) {
    for (const Dds& a : dds) {
      if ((a.address >> 24) == 127)
        c.Error(L.OfHostField(a.host, "dds_interface"), HostWhere(d.host(a.host), a.host),
                "a loopback DDS address in a deployment of several hosts");
    }
  }
}

void Validate(const Deployment& d, Checker& c) {
  const Lines& L = c.lines_;
  ValidateSettings(d, c);
  if (d.host_size() == 0) {
    c.Error(0, "", "no host: a deployment needs at least one 'host { ... }'");
    return;
  }
  std::map<std::string, int> host_names;
  std::map<unsigned, std::string> addresses;  // address -> "host/iface"
  std::vector<Dds> dds;
  Census census;
  for (int h = 0; h < d.host_size(); ++h) {
    const Host& host = d.host(h);
    const std::string where = HostWhere(host, h);
    if (!ValidName(host.name()))
      c.Error(L.OfHost(h), where,
              "name '" + host.name() + "' must be 1..32 characters of a-z 0-9 '-'");
    if (auto [it, fresh] = host_names.emplace(host.name(), h); !fresh)
      c.Error(L.OfHost(h), where,
              "duplicate host name (also host[" + std::to_string(it->second) + "])");
    if (host.interface_size() == 0)
      c.Error(L.OfHost(h), where, "no interface: list the host's network interfaces");
    ValidateInterfaces(host, h, c, addresses, dds);
    ValidateProcesses(host, h, c, census);
  }
  ValidateCensus(census, c);
  ValidateDdsNetworks(d, dds, c);
}


// Validates a parsed deployment; the defaults fill what it leaves out once it is valid.
LoadedDeployment Finish(Deployment d, const std::string& name, const Lines& lines) {
  LoadedDeployment out;
  Checker c(name, lines);
  Validate(d, c);
  out.errors = std::move(c.errors);
  out.ok = out.errors.empty();
  if (out.ok) ApplyDefaults(d);
  out.deployment = std::move(d);
  return out;
}

}  // namespace

LoadedDeployment ParseDeployment(const std::string& text, const std::string& name) {
  // The parser every text-format file of the system goes through (config/, text_format.hpp):
  // its errors name the file, line and column, and an unknown field its path, the known
  // fields and the nearest one.
  Deployment d;
  gp::TextFormat::ParseInfoTree tree;
  std::vector<config::ConfigIssue> issues;
  if (!config::text_format::ParseTextFormat(text, name, d, tree, issues)) {
    LoadedDeployment out;
    for (const config::ConfigIssue& issue : issues) out.errors.push_back(issue.ToString());
    return out;
  }
  return Finish(std::move(d), name, Lines{&tree});
}

LoadedDeployment LoadDeployment(const std::string& path) {
  std::ifstream in(path);
  if (!in) {
    LoadedDeployment out;
    out.errors.push_back(path + ": error: cannot open the deployment file");
    return out;
  }
  std::stringstream ss;
  ss << in.rdbuf();
  return ParseDeployment(ss.str(), path);
}

void ApplyDefaults(Deployment& d) {
  if (d.bin_dir().empty()) d.set_bin_dir(kDefaultBinDir);
  if (d.config_dir().empty()) d.set_config_dir(kDefaultConfigDir);
  if (d.record_dir().empty()) d.set_record_dir(kDefaultRecordDir);
  if (d.rig_file().empty()) d.set_rig_file(d.config_dir() + "/rig.textproto");
  if (d.security().certificate_days() == 0)
    d.mutable_security()->set_certificate_days(kDefaultCertificateDays);
  auto* sec = d.mutable_security();
  if (sec->metadata_protection() == deployment::PROTECTION_UNSPECIFIED)
    sec->set_metadata_protection(kDefaultMetadataProtection);
  if (sec->discovery_protection() == deployment::PROTECTION_UNSPECIFIED)
    sec->set_discovery_protection(deployment::ENCRYPT);
  if (sec->liveliness_protection() == deployment::PROTECTION_UNSPECIFIED)
    sec->set_liveliness_protection(deployment::ENCRYPT);
  if (sec->loop_metadata_protection() == deployment::PROTECTION_UNSPECIFIED)
    sec->set_loop_metadata_protection(sec->metadata_protection());
  auto* t = d.mutable_timing();
  if (t->lockstep_timeout_s() == 0) t->set_lockstep_timeout_s(10.0);
  if (t->watchdog_s() == 0)
    t->set_watchdog_s(d.mode() == deployment::REALTIME ? 1.0 : 3.0 * t->lockstep_timeout_s());
  if (t->stale_ticks() == 0) t->set_stale_ticks(15);
  if (t->startup_timeout_s() == 0) t->set_startup_timeout_s(300.0);
}

std::string NodeName(const Process& p) {
  switch (p.role()) {
    case deployment::PLANT: return "plant";
    case deployment::SUPERVISOR: return "supervisor";
    case deployment::LEG:
      return "leg" + std::to_string(p.leg()) + (p.standby() ? "_standby" : "");
    case deployment::RECORDER: return "recorder";
    case deployment::OPERATOR: return "operator";
    case deployment::BRIDGE: return "bridge";
    default: return "unknown";
  }
}

std::vector<ProcessPlan> PlanProcesses(const Deployment& d) {
  std::vector<ProcessPlan> plans;
  for (int h = 0; h < d.host_size(); ++h) {
    for (int p = 0; p < d.host(h).process_size(); ++p) {
      ProcessPlan plan;
      plan.host = d.host(h).name();
      plan.host_index = h;
      plan.process_index = p;
      plan.process = d.host(h).process(p);
      plan.node = NodeName(plan.process);
      std::string unit = plan.node;
      for (char& ch : unit)
        if (ch == '_') ch = '-';
      plan.unit = "hexa-" + unit + ".service";
      plan.has_unit = plan.process.role() != deployment::OPERATOR &&
                      plan.process.role() != deployment::BRIDGE;
      plans.push_back(std::move(plan));
    }
  }
  return plans;
}

std::string SubjectOf(const Deployment& d, const std::string& node) {
  return "CN=" + node + ",O=HexaTaar,OU=" + d.name();
}

namespace {

// A decimal number of 1..max_digits digits without a leading zero ("0" itself is fine): glibc
// reads "010" as octal 8, so a leading zero would mean one address here and another in the
// generated configuration.
bool ParseDecimal(const std::string& text, std::size_t& at, int max_digits, unsigned& value) {
  const std::size_t start = at;
  value = 0;
  while (at < text.size() && text[at] >= '0' && text[at] <= '9' &&
         at - start < static_cast<std::size_t>(max_digits)) {
    value = value * 10 + static_cast<unsigned>(text[at] - '0');
    ++at;
  }
  const std::size_t digits = at - start;
  if (digits == 0) return false;
  if (at < text.size() && text[at] >= '0' && text[at] <= '9') return false;  // too many digits
  return !(digits > 1 && text[start] == '0');
}

}  // namespace

bool ParseIpv4Cidr(const std::string& text, unsigned& address, int& prefix) {
  unsigned b[4];
  std::size_t at = 0;
  for (int k = 0; k < 4; ++k) {
    if (!ParseDecimal(text, at, 3, b[k]) || b[k] > 255) return false;
    if (at >= text.size() || text[at] != (k < 3 ? '.' : '/')) return false;
    ++at;
  }
  unsigned pre = 0;
  if (!ParseDecimal(text, at, 2, pre) || at != text.size() || pre > 32) return false;
  address = (b[0] << 24) | (b[1] << 16) | (b[2] << 8) | b[3];
  prefix = static_cast<int>(pre);
  return true;
}

std::string AddressOf(const std::string& cidr) { return cidr.substr(0, cidr.find('/')); }

const deployment::Interface& DdsInterface(const Host& host) {
  for (const auto& i : host.interface())
    if (i.name() == host.dds_interface()) return i;
  return host.interface(0);
}

const char* ToString(Role role) {
  switch (role) {
    case deployment::PLANT: return "PLANT";
    case deployment::SUPERVISOR: return "SUPERVISOR";
    case deployment::LEG: return "LEG";
    case deployment::RECORDER: return "RECORDER";
    case deployment::OPERATOR: return "OPERATOR";
    case deployment::BRIDGE: return "BRIDGE";
    default: return "ROLE_UNSPECIFIED";
  }
}

const char* ToString(deployment::Mode mode) {
  switch (mode) {
    case deployment::LOCKSTEP: return "lockstep";
    case deployment::REALTIME: return "realtime";
    default: return "unspecified";
  }
}

}  // namespace hexa::deploy
