// DDS Security documents of a deployment (docs/security.md): the governance and each
// identity's permissions, unsigned (deploy/make_security.sh signs them with the project CA).
#include <ctime>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "generate.hpp"
#include "security_check.hpp"
#include "hexa/comm/partition.hpp"
#include "hexa/comm/qos.hpp"

namespace hexa::deploy {
namespace {

using deployment::Deployment;
using deployment::Role;

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
      // (the plant's interlock, docs/faults.md). OperatorCommand: the operator's estop and
      // reset reach the rig directly (docs/faults.md, "Emergency stop").
      p.subscribe = {valve_any, {kLegSetpointTopic, {}}, {kOperatorCommandTopic, {}}, status, faults};
      break;
    case deployment::LEG:
      // FaultEvent: the leg reports its own held-control episodes (bad input, stale setpoint).
      p.publish = {{kValveCommandTopic, {LegPartition(leg)}}, status, faults};
      p.subscribe = {{kLegSensorsTopic, {LegPartition(leg)}}, {kLegSetpointTopic, {LegPartition(leg)}}};
      break;
    case deployment::SUPERVISOR:
      p.publish = {{kLegSetpointTopic, {"", any_leg}}, {kPoseReportTopic, {}}, status, faults};
      // NodeStatus: the plant's answer to an activation (docs/faults.md, "Hardware lifecycle").
      p.subscribe = {{kLegSensorsTopic, {}}, {kImuSampleTopic, {}}, {kOperatorCommandTopic, {}},
                     faults, valve_any, status};
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
     << "        <not_before>" << FormatUtc(from, kPermissionsTimeFormat) << "</not_before>\n"
     << "        <not_after>" << FormatUtc(to, kPermissionsTimeFormat) << "</not_after>\n"
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

}  // namespace hexa::deploy
