#include "generate.hpp"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "hexa/comm/command_auth.hpp"
#include "hexa/comm/partition.hpp"
#include "hexa/comm/qos.hpp"

namespace hexa::deploy {
namespace {

namespace fs = std::filesystem;
using deployment::Deployment;
using deployment::Host;
using deployment::Role;

std::string Fmt(double v) {
  std::ostringstream os;
  os << v;
  return os.str();
}

// What each role may publish and subscribe (the access-control table of docs/security.md): only the
// plant / I/O node publishes sensors, IMU, ground truth and the tracker's poses; only leg N's identities publish
// ValveCommand, and only in partition LegPartition(N); only the supervisor publishes
// setpoints and pose reports; only the operator publishes OperatorCommand (and reads NodeStatus for the answer); the recorder
// subscribes to everything and publishes nothing but its own NodeStatus (the plant waits for
// it). Partitions follow the loop's routing (comm/partition.hpp): the plant and the
// supervisor write LegSensors / LegSetpoint in the default partition (supervisor, recorder)
// and in each leg's partition; leg N reads them in its own partition only, so a leg identity
// cannot even subscribe to another leg's sensors or setpoints.
struct TopicRule {
  std::string_view topic;
  // Empty: the default partition only (no <partitions> element). "" in the list: the
  // default partition next to others (an empty <partition/>).
  std::vector<std::string> partitions;
};
struct RolePermissions {
  std::vector<TopicRule> publish, subscribe;
};

RolePermissions PermissionsOf(Role role, int leg) {
  using namespace hexa::comm;
  const TopicRule status{kNodeStatusTopic, {}}, faults{kFaultEventTopic, {}};
  const std::string any_leg = "hexa.leg*";  // LegPartition(1..6)
  const TopicRule valve_any{kValveCommandTopic, {"", any_leg}};  // per-leg readers, the recorder
  RolePermissions p;
  switch (role) {
    case deployment::PLANT:
      // TrackerPose: the external pose instrument of a calibration session (--tracker); the
      // plant creates its writer in every session.
      p.publish = {{kLegSensorsTopic, {"", any_leg}}, {kImuSampleTopic, {}}, {kGroundTruthTopic, {}},
                   {kTrackerPoseTopic, {}}, status, faults};
      // FaultEvent: the supervisor's FAULT_SENSOR_INCONSISTENT closes that leg's valve
      // (the plant's interlock, docs/faults.md).
      p.subscribe = {valve_any, {kLegSetpointTopic, {}}, status, faults};
      break;
    case deployment::LEG:
      // FaultEvent: the leg reports its own held-control episodes (bad input, stale setpoint).
      p.publish = {{kValveCommandTopic, {LegPartition(leg)}}, status, faults};
      p.subscribe = {{kLegSensorsTopic, {LegPartition(leg)}}, {kLegSetpointTopic, {LegPartition(leg)}}};
      break;
    case deployment::SUPERVISOR:
      p.publish = {{kLegSetpointTopic, {"", any_leg}}, {kPoseReportTopic, {}}, status, faults};
      p.subscribe = {{kLegSensorsTopic, {}}, {kImuSampleTopic, {}}, {kOperatorCommandTopic, {}},
                     faults, valve_any};
      break;
    case deployment::RECORDER:
      p.publish = {status};
      p.subscribe = {{kLegSensorsTopic, {}}, valve_any, {kImuSampleTopic, {}},
                     {kLegSetpointTopic, {}}, {kPoseReportTopic, {}}, {kGroundTruthTopic, {}},
                     {kTrackerPoseTopic, {}}, {kOperatorCommandTopic, {}}, status, faults};
      break;
    case deployment::OPERATOR:
      p.publish = {{kOperatorCommandTopic, {}}};
      // NodeStatus: the supervisor's answer to a command (accepted / refused) comes in its
      // status detail, which hexa_operator waits for (docs/exit_codes.md).
      p.subscribe = {status};
      break;
    case deployment::BRIDGE:  // Foxglove viewer: reads everything, writes nothing
      p.subscribe = {{kLegSensorsTopic, {}}, valve_any, {kImuSampleTopic, {}},
                     {kLegSetpointTopic, {}}, {kPoseReportTopic, {}}, {kGroundTruthTopic, {}},
                     {kTrackerPoseTopic, {}}, {kOperatorCommandTopic, {}}, status, faults};
      break;
    default:
      break;
  }
  return p;
}

std::string IsoTime(std::time_t t) {
  char buf[32];
  std::tm tm{};
  gmtime_r(&t, &tm);
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%S", &tm);
  return buf;
}

std::string RulesXml(const std::vector<TopicRule>& rules, const char* kind, const char* indent) {
  // Group by partition set so that each <publish>/<subscribe> block has one.
  std::map<std::vector<std::string>, std::vector<std::string_view>> by_partitions;
  for (const auto& r : rules) by_partitions[r.partitions].push_back(r.topic);
  std::ostringstream os;
  for (const auto& [partitions, topics] : by_partitions) {
    os << indent << "<" << kind << ">\n" << indent << "  <topics>\n";
    for (auto t : topics) os << indent << "    <topic>" << t << "</topic>\n";
    os << indent << "  </topics>\n";
    if (!partitions.empty()) {
      os << indent << "  <partitions>";
      for (const auto& part : partitions) os << "<partition>" << part << "</partition>";
      os << "</partitions>\n";
    }
    os << indent << "</" << kind << ">\n";
  }
  return os.str();
}

bool WriteFile(const fs::path& path, const std::string& text, GenerateResult& result,
               fs::perms perms = fs::perms::owner_read | fs::perms::owner_write |
                                 fs::perms::group_read | fs::perms::others_read) {
  std::error_code ec;
  fs::create_directories(path.parent_path(), ec);
  std::ofstream out(path);
  out << text;
  out.close();
  if (!out) {
    result.error = "cannot write '" + path.string() + "'";
    return false;
  }
  fs::permissions(path, perms, ec);
  result.files.push_back(path.string());
  return true;
}

std::string Quote(const std::string& word) {
  std::string out;
  bool needs_quotes = word.empty();
  for (char c : word) {
    if (c == ' ' || c == '\t' || c == '"' || c == '\'' || c == '\\') needs_quotes = true;
    if (c == '$') out += "$$";
    else if (c == '%') out += "%%";
    else if (c == '"' || c == '\\') out += std::string("\\") + c;
    else out += c;
  }
  return needs_quotes ? "\"" + out + "\"" : out;
}

bool HasRole(const Deployment& d, Role role) {
  for (const auto& h : d.host())
    for (const auto& p : h.process())
      if (p.role() == role) return true;
  return false;
}

// The roles that hold the CPU wake-up latency limit (services/common ApplyScheduling).
bool HostHasControlProcess(const Host& host) {
  for (const auto& p : host.process())
    if (p.role() == deployment::PLANT || p.role() == deployment::LEG ||
        p.role() == deployment::SUPERVISOR)
      return true;
  return false;
}

int DefaultPriority(Role role) {
  switch (role) {
    // The legs highest: the tightest deadline (10 ms lease) and the shortest work; a plant or
    // supervisor above them on their CPU made them lapse (docs/measurements/deployment.md, "Where the
    // lapses' milliseconds go"). The same defaults as the services' own.
    case deployment::PLANT: return 70;        // hexa_plant_sim: late, its schedule slips
    case deployment::LEG: return 80;          // hexa_leg_ctrl
    case deployment::SUPERVISOR: return 75;   // hexa_task_space
    case deployment::RECORDER: return 50;     // below the loop; starved, it loses samples
    default: return 0;
  }
}

}  // namespace

std::string CycloneXml(const Deployment& d, const Host& host, const HostPaths& paths) {
  const auto& iface = DdsInterface(host);
  std::size_t most = 0;
  for (const auto& h : d.host()) most = std::max<std::size_t>(most, h.process_size());
  std::ostringstream os;
  os << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
     << "<!-- Generated by hexa_deploy from deployment '" << d.name() << "' for host '"
     << host.name() << "'. Do not edit: edit the deployment file and generate again.\n"
     << "     DDS runs on " << iface.name() << " (" << iface.address()
     << ") only; discovery is unicast to the listed peers. -->\n"
     << "<CycloneDDS xmlns=\"https://cdds.io/config\">\n"
     << "  <!-- Domain id=\"any\": a process started on another domain still gets these settings\n"
     << "       (and, when secured, fails on the governance's domain instead of running open). -->\n"
     << "  <Domain id=\"any\">\n"
     << "    <General>\n"
     << "      <Interfaces>\n"
     << "        <NetworkInterface name=\"" << iface.name() << "\" multicast=\"false\"/>\n"
     << "      </Interfaces>\n"
     << "      <AllowMulticast>false</AllowMulticast>\n"
     << "      <DontRoute>true</DontRoute>\n"
     << "    </General>\n"
     << "    <Discovery>\n"
     << "      <ParticipantIndex>auto</ParticipantIndex>\n"
     // Unicast discovery probes participant indices 0..max on every peer: room for every
     // process of the busiest host plus operator and tools.
     << "      <MaxAutoParticipantIndex>" << most + 4 << "</MaxAutoParticipantIndex>\n"
     << "      <Peers>\n";
  std::set<std::string> peers;
  for (const auto& h : d.host()) peers.insert(AddressOf(DdsInterface(h).address()));
  for (const auto& p : peers) os << "        <Peer address=\"" << p << "\"/>\n";
  os << "      </Peers>\n"
     << "    </Discovery>\n"
     // As deploy/cyclonedds-loopback.xml: reliable writers ask for acknowledgements every
     // 10 ms instead of Cyclone's 100 ms; the lockstep plant's sync with the recorder waits
     // for them (at 100 ms lockstep with a recorder ran at 0.5x real time, docs/performance.md).
     // And as there: deleting a writer waits at most 250 ms (Cyclone: 1 s per writer) for
     // acknowledgements from readers that may be gone (a session's shutdown, docs/robustness.md).
     << "    <Internal>\n"
     << "      <HeartbeatInterval minsched=\"10 ms\">10 ms</HeartbeatInterval>\n"
     << "      <WriterLingerDuration>250 ms</WriterLingerDuration>\n"
     << "    </Internal>\n";
  if (!d.security().audit_dir().empty()) {
    os << "    <Tracing>\n"
       << "      <Category>discovery</Category>\n"
       << "      <OutputFile>" << d.security().audit_dir() << "/dds-${HEXA_IDENTITY}.log</OutputFile>\n"
       << "    </Tracing>\n";
  }
  if (d.security().enabled()) {
    const std::string sec = "file:" + paths.config_dir + "/security";
    os << "    <!-- DDS Security: authentication (project CA, one identity per process: each unit\n"
       << "         sets HEXA_IDENTITY), access control (signed governance and permissions),\n"
       << "         encryption. A missing or invalid file fails participant creation: there is\n"
       << "         no insecure fallback. -->\n"
       << "    <Security>\n"
       << "      <Authentication>\n"
       << "        <Library path=\"dds_security_auth\" initFunction=\"init_authentication\" "
          "finalizeFunction=\"finalize_authentication\"/>\n"
       << "        <IdentityCA>" << sec << "/ca_cert.pem</IdentityCA>\n"
       << "        <IdentityCertificate>" << sec << "/${HEXA_IDENTITY}/cert.pem</IdentityCertificate>\n"
       << "        <PrivateKey>" << sec << "/${HEXA_IDENTITY}/key.pem</PrivateKey>\n"
       << "      </Authentication>\n"
       << "      <AccessControl>\n"
       << "        <Library path=\"dds_security_ac\" initFunction=\"init_access_control\" "
          "finalizeFunction=\"finalize_access_control\"/>\n"
       << "        <PermissionsCA>" << sec << "/ca_cert.pem</PermissionsCA>\n"
       << "        <Governance>" << sec << "/governance.p7s</Governance>\n"
       << "        <Permissions>" << sec << "/${HEXA_IDENTITY}/permissions.p7s</Permissions>\n"
       << "      </AccessControl>\n"
       << "      <Cryptographic>\n"
       << "        <Library path=\"dds_security_crypto\" initFunction=\"init_crypto\" "
          "finalizeFunction=\"finalize_crypto\"/>\n"
       << "      </Cryptographic>\n"
       << "    </Security>\n";
  }
  os << "  </Domain>\n"
     << "</CycloneDDS>\n";
  return os.str();
}

namespace {
const char* ProtectionName(deployment::Protection p) {
  switch (p) {
    case deployment::NONE: return "NONE";
    case deployment::SIGN: return "SIGN";
    default: return "ENCRYPT";  // ENCRYPT, and an unset field (ApplyDefaults not called)
  }
}
}  // namespace

std::string GovernanceXml(const Deployment& d) {
  const auto& sec = d.security();
  const char* metadata = ProtectionName(sec.metadata_protection());
  const char* loop = ProtectionName(sec.loop_metadata_protection() == deployment::PROTECTION_UNSPECIFIED
                                        ? sec.metadata_protection()
                                        : sec.loop_metadata_protection());
  std::ostringstream os;
  os << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
     << "<!-- Governance of deployment '" << d.name() << "' (generated by hexa_deploy). Domain "
     << d.domain_id() << ": only authenticated participants join; discovery and liveliness\n"
     << "     are protected; every topic is access-controlled for reading and writing, its data\n"
     << "     are encrypted on the wire, its metadata (submessages) protected: " << metadata
     << " (the 1 kHz loop topics: " << loop << "). -->\n"
     << "<dds xmlns:xsi=\"http://www.w3.org/2001/XMLSchema-instance\" "
        "xsi:noNamespaceSchemaLocation=\"http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_governance.xsd\">\n"
     << "  <domain_access_rules>\n"
     << "    <domain_rule>\n"
     << "      <domains><id>" << d.domain_id() << "</id></domains>\n"
     << "      <allow_unauthenticated_participants>false</allow_unauthenticated_participants>\n"
     << "      <enable_join_access_control>true</enable_join_access_control>\n"
     << "      <discovery_protection_kind>" << ProtectionName(sec.discovery_protection())
     << "</discovery_protection_kind>\n"
     << "      <liveliness_protection_kind>" << ProtectionName(sec.liveliness_protection())
     << "</liveliness_protection_kind>\n"
     << "      <rtps_protection_kind>NONE</rtps_protection_kind>\n"
     << "      <topic_access_rules>\n";
  // The first rule whose expression matches a topic applies (DDS Security 9.4.1.2.7): the
  // 1 kHz loop topics first when their metadata protection differs.
  auto rule = [&](std::string_view expression, const char* metadata_kind) {
    os << "        <topic_rule>\n"
       << "          <topic_expression>" << expression << "</topic_expression>\n"
       << "          <enable_discovery_protection>true</enable_discovery_protection>\n"
       << "          <enable_liveliness_protection>true</enable_liveliness_protection>\n"
       << "          <enable_read_access_control>true</enable_read_access_control>\n"
       << "          <enable_write_access_control>true</enable_write_access_control>\n"
       << "          <metadata_protection_kind>" << metadata_kind << "</metadata_protection_kind>\n"
       << "          <data_protection_kind>ENCRYPT</data_protection_kind>\n"
       << "        </topic_rule>\n";
  };
  if (std::string_view(loop) != metadata)
    for (auto topic : {comm::kLegSensorsTopic, comm::kValveCommandTopic, comm::kGroundTruthTopic}) rule(topic, loop);
  rule("*", metadata);
  os << "      </topic_access_rules>\n"
     << "    </domain_rule>\n"
     << "  </domain_access_rules>\n"
     << "</dds>\n";
  return os.str();
}

std::string PermissionsXml(const Deployment& d, const std::string& node, Role role, int leg,
                           std::time_t now) {
  const RolePermissions p = PermissionsOf(role, leg);
  const std::time_t from = now - 3600;  // an hour of clock skew between boards
  const std::time_t to = now + static_cast<std::time_t>(d.security().certificate_days()) * 86400;
  std::ostringstream os;
  os << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
     << "<!-- Permissions of '" << node << "' (" << ToString(role) << ") in deployment '"
     << d.name() << "' (generated by hexa_deploy). -->\n"
     << "<dds xmlns:xsi=\"http://www.w3.org/2001/XMLSchema-instance\" "
        "xsi:noNamespaceSchemaLocation=\"http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_permissions.xsd\">\n"
     << "  <permissions>\n"
     << "    <grant name=\"" << node << "\">\n"
     << "      <subject_name>" << SubjectOf(d, node) << "</subject_name>\n"
     << "      <validity>\n"
     << "        <not_before>" << IsoTime(from) << "</not_before>\n"
     << "        <not_after>" << IsoTime(to) << "</not_after>\n"
     << "      </validity>\n"
     << "      <allow_rule>\n"
     << "        <domains><id>" << d.domain_id() << "</id></domains>\n"
     << RulesXml(p.publish, "publish", "        ")
     << RulesXml(p.subscribe, "subscribe", "        ")
     << "      </allow_rule>\n"
     << "      <default>DENY</default>\n"
     << "    </grant>\n"
     << "  </permissions>\n"
     << "</dds>\n";
  return os.str();
}

std::vector<std::string> CommandLine(const Deployment& d, const ProcessPlan& plan,
                                     const HostPaths& paths) {
  const auto& p = plan.process;
  const std::string bin = d.bin_dir() + "/";
  const std::string dds_config = paths.config_dir + "/cyclonedds.xml";
  const bool recorder = HasRole(d, deployment::RECORDER);
  const std::string domain = std::to_string(d.domain_id());
  const std::string startup = Fmt(d.timing().startup_timeout_s());
  std::vector<std::string> argv;
  // Real time: the SCHED_FIFO priority the unit gives (CPUSchedulingPriority=), also asked
  // for by the process itself (it would otherwise use its own default).
  const int prio = p.rt_priority() != 0 ? static_cast<int>(p.rt_priority()) : DefaultPriority(p.role());
  const bool realtime = d.mode() == deployment::REALTIME;
  auto common = [&] {
    argv.insert(argv.end(), {"--domain", domain, "--mode", ToString(d.mode()), "--rig",
                             d.rig_file(), "--dds-config", dds_config, "--lockstep-timeout",
                             Fmt(d.timing().lockstep_timeout_s())});
    if (realtime) argv.insert(argv.end(), {"--rt-priority", std::to_string(prio)});
  };
  switch (p.role()) {
    case deployment::PLANT:
      argv = {p.executable().empty() ? bin + "hexa_plant_sim" : p.executable()};
      common();
      argv.insert(argv.end(), {"--legs", "6", "--supervisor", "--stale-ticks",
                               std::to_string(d.timing().stale_ticks()), "--startup-timeout",
                               startup});
      if (recorder) argv.push_back("--expect-recorder");
      break;
    case deployment::LEG:
      argv = {p.executable().empty() ? bin + "hexa_leg_ctrl" : p.executable()};
      common();
      argv.insert(argv.end(), {"--leg", std::to_string(p.leg()), "--valve-readers",
                               recorder ? "2" : "1", "--startup-timeout", startup});
      if (p.standby()) argv.push_back("--standby");
      break;
    case deployment::SUPERVISOR:
      argv = {p.executable().empty() ? bin + "hexa_task_space" : p.executable()};
      common();
      argv.insert(argv.end(), {"--startup-timeout", startup});
      if (recorder) argv.insert(argv.end(), {"--pose-readers", "1"});
      break;
    case deployment::RECORDER: {
      // One file per start: the shell names it by the UTC time (exec keeps the PID, so
      // Type=notify still hears the recorder itself).
      std::string cmd = "exec " + (p.executable().empty() ? bin + "hexa_recorder" : p.executable()) +
                        " record --output " + d.record_dir() +
                        "/session-$(date -u +%Y%m%d-%H%M%S).mcap --domain " + domain +
                        " --dds-config " + dds_config;
      // Real time: the periodic topics best effort, so that no control writer repairs what
      // the recorder's link drops (docs/measurements/deployment.md, "The lossy recorder link").
      if (realtime) cmd += " --rt-priority " + std::to_string(prio) + " --periodic-reliability best-effort";
      for (const auto& a : p.arg()) cmd += " " + a;
      return {"/bin/sh", "-c", cmd};
    }
    default:
      return {};
  }
  for (const auto& a : p.arg()) argv.push_back(a);
  return argv;
}

std::string JoinCommandLine(const std::vector<std::string>& argv) {
  std::string out;
  for (const auto& a : argv) out += (out.empty() ? "" : " ") + Quote(a);
  return out;
}

std::vector<std::string> SplitCommandLine(const std::string& line) {
  std::vector<std::string> words;
  std::string cur;
  bool in_word = false;
  char quote = 0;
  for (std::size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quote != 0) {
      if (c == quote) {
        quote = 0;
      } else if (c == '\\' && quote == '"' && i + 1 < line.size()) {
        cur += line[++i];
      } else if ((c == '$' || c == '%') && i + 1 < line.size() && line[i + 1] == c) {
        cur += c;
        ++i;
      } else {
        cur += c;
      }
      continue;
    }
    if (c == ' ' || c == '\t') {
      if (in_word) words.push_back(cur);
      cur.clear();
      in_word = false;
    } else if (c == '"' || c == '\'') {
      quote = c;
      in_word = true;
    } else if ((c == '$' || c == '%') && i + 1 < line.size() && line[i + 1] == c) {
      cur += c;
      ++i;
      in_word = true;
    } else {
      cur += c;
      in_word = true;
    }
  }
  if (in_word) words.push_back(cur);
  return words;
}

std::string UnitFileText(const Deployment& d, const ProcessPlan& plan, const HostPaths& paths) {
  const auto& p = plan.process;
  const bool realtime = d.mode() == deployment::REALTIME;
  std::ostringstream os;
  std::string what;
  switch (p.role()) {
    case deployment::PLANT: what = "plant / I/O node (clock master)"; break;
    case deployment::SUPERVISOR: what = "task-space supervisor"; break;
    case deployment::LEG:
      what = "leg " + std::to_string(p.leg()) + (p.standby() ? " hot-standby" : "") + " controller";
      break;
    case deployment::RECORDER: what = "recorder"; break;
    default: what = "process"; break;
  }
  os << "# Generated by hexa_deploy from deployment '" << d.name() << "' for host '" << plan.host
     << "'. Do not edit: edit the deployment file and generate again.\n"
     << "[Unit]\n"
     << "Description=HexaTaar " << what << " (" << d.name() << ", " << ToString(d.mode()) << ")\n"
     // No man: reference: systemd-analyze verify runs man(1) for it, absent on a minimal board.
     << "Documentation=file:/usr/share/doc/hexataar-control/deployment.md\n"
     << "After=network-online.target\n"
     << "Wants=network-online.target\n"
     << "PartOf=hexa.target\n"
     // A few quick restarts, then systemd gives up and the unit shows failed.
     << "StartLimitIntervalSec=60\n"
     << "StartLimitBurst=5\n"
     << "\n[Service]\n"
     // READY=1 when the node reports RUNNING (services/common service_manager).
     << "Type=notify\n"
     << "NotifyAccess=main\n"
     // WATCHDOG=1 comes from the control loop: a hung loop is killed (SIGABRT) and restarted.
     << "WatchdogSec=" << Fmt(d.timing().watchdog_s()) << "s\n"
     << "TimeoutStartSec=" << Fmt(d.timing().startup_timeout_s() + 30) << "s\n"
     << "TimeoutStopSec=10s\n"
     << "User=hexa\n"
     << "Group=hexa\n"
     << "Environment=HEXA_IDENTITY=" << plan.node << "\n"
     << "Environment=CYCLONEDDS_URI=file://" << paths.config_dir << "/cyclonedds.xml\n"
     // The session key that authenticates commands (docs/faults.md, "Foreign commands").
     << "Environment=" << comm::kSessionKeyEnvironment << "=" << paths.config_dir << "/session.key\n";
  if (d.security().enabled()) {
    // Clear errors before the service starts (missing, expired or foreign-CA files); the
    // service itself would fail to create its participant anyway: never an open fallback.
    os << "ExecStartPre=" << d.bin_dir() << "/hexa_deploy verify-security --dds-config "
       << paths.config_dir << "/cyclonedds.xml --identity " << plan.node << " --domain "
       << d.domain_id() << "\n";
  }
  os << "ExecStart=" << JoinCommandLine(CommandLine(d, plan, paths)) << "\n";
  // Restart policy per role. Lockstep is a reproducible run: a restarted process would
  // start from tick 0 or an empty controller state, so nothing restarts and the run fails.
  // Exit 2 is a usage or configuration error: a restart cannot mend it.
  if (!realtime) {
    os << "Restart=no\n";
  } else if (p.role() == deployment::RECORDER) {
    os << "Restart=always\nRestartSec=1s\n";  // never stop recording; a new file per start
  } else {
    // Plant / I/O node: comes back with its valves at null until fresh commands arrive.
    // Legs: a restarted primary rejoins (its standby, if any, holds the valve meanwhile).
    // Supervisor: restarts IDLE and waits for an operator command (safe by construction).
    const char* delay = p.role() == deployment::LEG ? "500ms" : p.role() == deployment::PLANT ? "2s" : "1s";
    os << "Restart=on-failure\nRestartSec=" << delay << "\n";
  }
  os << "RestartPreventExitStatus=2\n";
  // Resources for real time: the services also call sched_setscheduler + mlockall
  // themselves before creating the participant (Cyclone's threads inherit the policy).
  os << "LimitMEMLOCK=infinity\n";
  const int prio = p.rt_priority() != 0 ? static_cast<int>(p.rt_priority()) : DefaultPriority(p.role());
  if (realtime && prio > 0) {
    os << "CPUSchedulingPolicy=fifo\n"
       << "CPUSchedulingPriority=" << prio << "\n"
       << "LimitRTPRIO=" << std::max(prio, 80) << "\n"
       << "AmbientCapabilities=CAP_SYS_NICE CAP_IPC_LOCK\n"
       << "CapabilityBoundingSet=CAP_SYS_NICE CAP_IPC_LOCK\n";
  } else {
    os << "CapabilityBoundingSet=\n";
  }
  if (p.has_cpu()) os << "CPUAffinity=" << p.cpu() << "\n";
  // Hardening that costs the loop nothing.
  os << "NoNewPrivileges=yes\n"
     << "ProtectSystem=strict\n"
     << "ProtectHome=yes\n"
     << "PrivateTmp=yes\n"
     << "ProtectKernelTunables=yes\n"
     << "ProtectControlGroups=yes\n"
     << "RestrictAddressFamilies=AF_INET AF_INET6 AF_UNIX AF_NETLINK\n";
  if (!d.security().audit_dir().empty()) os << "ReadWritePaths=" << d.security().audit_dir() << "\n";
  if (p.role() == deployment::RECORDER) {
    // systemd creates the default directory for the service user; another one must exist.
    const std::string state = "/var/lib/";
    if (d.record_dir().rfind(state, 0) == 0)
      os << "StateDirectory=" << d.record_dir().substr(state.size()) << "\n";
    else
      os << "ReadWritePaths=" << d.record_dir() << "\n";
  }
  os << "\n[Install]\n"
     << "WantedBy=hexa.target\n";
  return os.str();
}

std::string CpuLatencyUdevRule(const Deployment& d) {
  std::ostringstream os;
  os << "# Generated by hexa_deploy from deployment '" << d.name() << "'. The plant, the leg\n"
     << "# controllers and the supervisor hold the CPU wake-up latency limit at 0 us while their\n"
     << "# loop runs (--cpu-latency-us, /dev/cpu_dma_latency, docs/performance.md). The device is\n"
     << "# root's (0600) and the units run as user hexa: without this rule they log \"CPU wake-up\n"
     << "# latency not limited (... Permission denied)\" and run without the hold.\n"
     << "KERNEL==\"cpu_dma_latency\", GROUP=\"hexa\", MODE=\"0660\"\n";
  return os.str();
}

std::string TargetFileText(const Deployment& d, const Host& host) {
  std::ostringstream os;
  os << "# Generated by hexa_deploy from deployment '" << d.name() << "' for host '" << host.name()
     << "'.\n"
     << "[Unit]\n"
     << "Description=HexaTaar control processes of host " << host.name() << " (" << d.name() << ")\n"
     << "Wants=network-online.target\n"
     << "After=network-online.target\n"
     << "\n[Install]\n"
     << "WantedBy=multi-user.target\n";
  return os.str();
}

GenerateResult Generate(const Deployment& d, const std::string& source_text,
                        const std::string& out_dir, const GenerateOptions& options) {
  GenerateResult result;
  const std::time_t now = options.now != 0 ? options.now : std::time(nullptr);
  const fs::path out = fs::absolute(out_dir);
  const auto plans = PlanProcesses(d);
  // One new session key for every host of the deployment (commands are authenticated in any
  // mode, secured or not: docs/faults.md, "Foreign commands"): OUT/session.key for the
  // operator's machine, etc/hexa/session.key on each host, readable by its owner and group.
  std::string key_text;
  {
    const fs::path key = out / "session.key";
    std::error_code ec;
    fs::create_directories(out, ec);
    fs::remove(key, ec);
    if (!comm::WriteNewSessionKey(key.string(), result.error)) return result;
    std::ifstream in(key);
    std::getline(in, key_text);
    key_text += "\n";
    result.files.push_back(key.string());
  }
  for (const Host& host : d.host()) {
    const fs::path root = out / "hosts" / host.name();
    HostPaths paths;
    paths.config_dir = options.in_place ? (root / d.config_dir().substr(1)).string() : d.config_dir();
    const fs::path conf = root / d.config_dir().substr(1);
    if (!WriteFile(conf / "cyclonedds.xml", CycloneXml(d, host, paths), result)) return result;
    if (!WriteFile(conf / "deployment.textproto", source_text, result)) return result;
    if (!WriteFile(conf / "session.key", key_text, result,
                   fs::perms::owner_read | fs::perms::owner_write | fs::perms::group_read))
      return result;
    const fs::path units = root / "lib/systemd/system";
    for (const auto& plan : plans) {
      if (plan.host != host.name() || !plan.has_unit) continue;
      if (!WriteFile(units / plan.unit, UnitFileText(d, plan, paths), result)) return result;
    }
    if (!WriteFile(units / "hexa.target", TargetFileText(d, host), result)) return result;
    // Real time: the service user may hold the CPU wake-up latency limit (udev applies the
    // rule at boot, or `udevadm trigger --sysname-match=cpu_dma_latency`).
    if (d.mode() == deployment::REALTIME && HostHasControlProcess(host) &&
        !WriteFile(root / "etc/udev/rules.d" / kCpuLatencyUdevRuleFile, CpuLatencyUdevRule(d), result))
      return result;
  }
  if (d.security().enabled()) {
    const fs::path src = out / "security-src";
    if (!WriteFile(src / "governance.xml", GovernanceXml(d), result)) return result;
    std::ostringstream ids;
    ids << "# identity host subject (generated by hexa_deploy; input of make_security.sh)\n";
    for (const auto& plan : plans) {
      if (!WriteFile(src / "permissions" / (plan.node + ".xml"),
                     PermissionsXml(d, plan.node, plan.process.role(),
                                    static_cast<int>(plan.process.leg()), now),
                     result))
        return result;
      ids << plan.node << " " << plan.host << " " << SubjectOf(d, plan.node) << "\n";
    }
    if (!WriteFile(src / "identities.txt", ids.str(), result)) return result;
  }
  result.ok = true;
  return result;
}

}  // namespace hexa::deploy
