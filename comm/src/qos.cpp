#include "hexa/comm/qos.hpp"

#include <cmath>
#include <cstdio>
#include <new>
#include <stdexcept>
#include <string>
#include <utility>

namespace hexa::comm {
namespace {

dds_duration_t SecondsToDuration(double seconds) {
  if (std::isinf(seconds)) return DDS_INFINITY;
  return static_cast<dds_duration_t>(std::llround(seconds * 1e9));
}

bool IsPeriodic(TopicKind kind) { return NominalPeriod_s(kind).has_value(); }

// Status and fault topics are the only ones a late joiner must see history of.
bool IsTransientLocal(TopicKind kind) {
  // LegSetpoint too: a leg controller whose reader matches the supervisor's writer only after
  // a setpoint was written still gets the newest one per leg. Lockstep depends on it: the
  // legs wait for the setpoint of tick 0 before answering tick 1, and the supervisor writes
  // the next one only after that (found by CI with hot standbys: 12 leg readers, a start-up
  // race, a deadlock at tick 1).
  return kind == TopicKind::kNodeStatus || kind == TopicKind::kFaultEvent ||
         kind == TopicKind::kLegSetpoint;
}

}  // namespace

std::string_view TopicName(TopicKind kind) {
  switch (kind) {
    case TopicKind::kLegSensors: return kLegSensorsTopic;
    case TopicKind::kValveCommand: return kValveCommandTopic;
    case TopicKind::kImuSample: return kImuSampleTopic;
    case TopicKind::kLegSetpoint: return kLegSetpointTopic;
    case TopicKind::kPoseReport: return kPoseReportTopic;
    case TopicKind::kGroundTruth: return kGroundTruthTopic;
    case TopicKind::kOperatorCommand: return kOperatorCommandTopic;
    case TopicKind::kNodeStatus: return kNodeStatusTopic;
    case TopicKind::kFaultEvent: return kFaultEventTopic;
    case TopicKind::kTrackerPose: return kTrackerPoseTopic;
  }
  return "hexa_unknown";
}

std::optional<double> NominalPeriod_s(TopicKind kind) {
  switch (kind) {
    case TopicKind::kLegSensors:
    case TopicKind::kValveCommand:
    case TopicKind::kGroundTruth: return 0.001;
    case TopicKind::kImuSample:
    case TopicKind::kLegSetpoint:
    case TopicKind::kPoseReport: return 0.005;
    case TopicKind::kTrackerPose: return 0.01;
    case TopicKind::kOperatorCommand:
    case TopicKind::kNodeStatus:  // 10 Hz + on change: no rate to enforce, state is what counts
    case TopicKind::kFaultEvent: return std::nullopt;
  }
  return std::nullopt;
}

void QosParams::Validate() const {
  if (deadline_period_s.has_value() && !(*deadline_period_s > 0.0)) {
    throw std::invalid_argument("QosParams.deadline_period_s = " +
                                std::to_string(*deadline_period_s) +
                                " s: must be > 0 (or +infinity for no deadline)");
  }
  if (!(valve_liveliness_lease_s > 0.0) || std::isinf(valve_liveliness_lease_s)) {
    throw std::invalid_argument("QosParams.valve_liveliness_lease_s = " +
                                std::to_string(valve_liveliness_lease_s) +
                                " s: must be finite and > 0");
  }
  if (control_reader_depth < 1 || control_reader_depth > 1000) {
    throw std::invalid_argument("QosParams.control_reader_depth = " +
                                std::to_string(control_reader_depth) + ": must be in [1, 1000]");
  }
  if (!(setpoint_liveliness_lease_s > 0.0)) {
    throw std::invalid_argument("QosParams.setpoint_liveliness_lease_s = " +
                                std::to_string(setpoint_liveliness_lease_s) +
                                " s: must be > 0 (or +infinity for none)");
  }
  if (user_data.size() > 256) {
    throw std::invalid_argument("QosParams.user_data is " + std::to_string(user_data.size()) +
                                " bytes: at most 256");
  }
  if (ownership_strength < 0) {
    throw std::invalid_argument("QosParams.ownership_strength = " +
                                std::to_string(ownership_strength) + ": must be >= 0");
  }
}

Qos::Qos() : qos_(dds_create_qos()) {
  if (qos_ == nullptr) throw std::bad_alloc();
}
Qos::~Qos() {
  if (qos_ != nullptr) dds_delete_qos(qos_);
}
Qos::Qos(Qos&& other) noexcept : qos_(std::exchange(other.qos_, nullptr)) {}
Qos& Qos::operator=(Qos&& other) noexcept {
  if (this != &other) {
    if (qos_ != nullptr) dds_delete_qos(qos_);
    qos_ = std::exchange(other.qos_, nullptr);
  }
  return *this;
}

std::string QosPolicyName(uint32_t policy_id) {
  switch (policy_id) {
    case DDS_USERDATA_QOS_POLICY_ID: return "USER_DATA";
    case DDS_DURABILITY_QOS_POLICY_ID: return "DURABILITY";
    case DDS_PRESENTATION_QOS_POLICY_ID: return "PRESENTATION";
    case DDS_DEADLINE_QOS_POLICY_ID: return "DEADLINE";
    case DDS_LATENCYBUDGET_QOS_POLICY_ID: return "LATENCY_BUDGET";
    case DDS_OWNERSHIP_QOS_POLICY_ID: return "OWNERSHIP";
    case DDS_OWNERSHIPSTRENGTH_QOS_POLICY_ID: return "OWNERSHIP_STRENGTH";
    case DDS_LIVELINESS_QOS_POLICY_ID: return "LIVELINESS";
    case DDS_TIMEBASEDFILTER_QOS_POLICY_ID: return "TIME_BASED_FILTER";
    case DDS_PARTITION_QOS_POLICY_ID: return "PARTITION";
    case DDS_RELIABILITY_QOS_POLICY_ID: return "RELIABILITY";
    case DDS_DESTINATIONORDER_QOS_POLICY_ID: return "DESTINATION_ORDER";
    case DDS_HISTORY_QOS_POLICY_ID: return "HISTORY";
    case DDS_RESOURCELIMITS_QOS_POLICY_ID: return "RESOURCE_LIMITS";
    case DDS_DURABILITYSERVICE_QOS_POLICY_ID: return "DURABILITY_SERVICE";
    default: return "policy " + std::to_string(policy_id);
  }
}

dds_duration_t DeadlinePeriod_ns(TopicKind kind, const QosParams& params) {
  const std::optional<double> nominal = NominalPeriod_s(kind);
  if (!nominal) return DDS_INFINITY;
  return SecondsToDuration(params.deadline_period_s.value_or(*nominal));
}

int32_t WriterHistoryDepth(TopicKind kind) {
  switch (kind) {
    case TopicKind::kLegSensors:
    case TopicKind::kValveCommand:
    // 3 s of samples per instance: what a reliable reader that stalls (the recorder behind
    // an fdatasync or descheduled on a loaded machine) can still get retransmitted; the
    // lockstep plant lets the loop run at most 1.3 s ahead of the recorder
    // (recorder_sync_window_ticks). A keep-last writer never blocks; the depth costs memory
    // only while a reader lags (about 1 MB for GroundTruth).
    case TopicKind::kGroundTruth: return 3000;  // 3 s at 1 kHz
    case TopicKind::kImuSample:
    case TopicKind::kLegSetpoint:
    case TopicKind::kPoseReport: return 600;  // 3 s at 200 Hz
    case TopicKind::kTrackerPose: return 300;  // 3 s at 100 Hz
    case TopicKind::kNodeStatus: return 1;   // per node: the current status is what matters
    case TopicKind::kFaultEvent: return 64;  // the last 64 faults for late joiners
    case TopicKind::kOperatorCommand: return 0;  // keep-all
  }
  return 1;
}

Qos MakeTopicQos(TopicKind kind) {
  Qos qos;
  dds_qset_reliability(qos.get(), DDS_RELIABILITY_RELIABLE, DDS_MSECS(100));
  dds_qset_durability(qos.get(), IsTransientLocal(kind) ? DDS_DURABILITY_TRANSIENT_LOCAL
                                                        : DDS_DURABILITY_VOLATILE);
  return qos;
}

bool ParseLegEndpointUserData(const std::string& text, int& leg, bool& standby) {
  int l = 0, sb = 0;
  if (std::sscanf(text.c_str(), "leg=%d standby=%d", &l, &sb) != 2 || l < 1) return false;
  leg = l;
  standby = sb != 0;
  return true;
}

Qos MakeQos(TopicKind kind, EndpointRole role, const QosParams& params) {
  params.Validate();
  Qos qos;
  dds_qos_t* q = qos.get();
  const bool writer = role == EndpointRole::kWriter;
  const bool recorder = role == EndpointRole::kRecorderReader;

  // Reliability. Event topics: RELIABLE everywhere. Periodic topics in lockstep: RELIABLE
  // everywhere (a lost sample would stall the tick). Periodic topics in real time: the writer
  // offers BEST_EFFORT, so every reader must request it (a reliable request does not match: Cyclone
  // reports REQUESTED_INCOMPATIBLE_QOS with the RELIABILITY policy). Not only to spare the writer
  // repairs: Debian's Cyclone DDS 0.10.2 drops the sample after every lost one for a best-effort
  // reader of a *reliable* writer (eclipse-cyclonedds issue 1561, fixed in 11.0), so a reliable
  // real-time writer cost its control readers a second tick per lost packet
  // (docs/measurements/deployment_recorder_link.md, "The lossy recorder link"). The recorder's
  // periodic readers follow recorder_periodic_best_effort (real time) instead of `lockstep`.
  // Writers use keep-last histories (below), so a reliable writer never blocks in write();
  // max_blocking_time only matters for the keep-all OperatorCommand writer.
  const bool reliable =
      !IsPeriodic(kind) ||
      (recorder ? !params.recorder_periodic_best_effort : params.lockstep);
  dds_qset_reliability(q, reliable ? DDS_RELIABILITY_RELIABLE : DDS_RELIABILITY_BEST_EFFORT,
                       DDS_MSECS(100));

  // History.
  if (writer) {
    const int32_t depth = WriterHistoryDepth(kind);
    if (depth == 0) {
      dds_qset_history(q, DDS_HISTORY_KEEP_ALL, DDS_LENGTH_UNLIMITED);
    } else {
      dds_qset_history(q, DDS_HISTORY_KEEP_LAST, depth);
    }
  } else if (recorder || kind == TopicKind::kOperatorCommand || kind == TopicKind::kFaultEvent) {
    dds_qset_history(q, DDS_HISTORY_KEEP_ALL, DDS_LENGTH_UNLIMITED);
  } else {
    dds_qset_history(q, DDS_HISTORY_KEEP_LAST, params.control_reader_depth);  // 1: newest only
  }

  // Durability: offered (writer) and requested (reader) alike.
  dds_qset_durability(q, IsTransientLocal(kind) ? DDS_DURABILITY_TRANSIENT_LOCAL
                                                : DDS_DURABILITY_VOLATILE);

  // Deadline. The recorder requests none (it would match any offer) and proves rates from
  // tick numbers instead; every other endpoint of a periodic topic offers / requests the
  // same period.
  if (IsPeriodic(kind) && !recorder) {
    dds_qset_deadline(q, DeadlinePeriod_ns(kind, params));
  }

  if (!params.user_data.empty()) {
    dds_qset_userdata(q, params.user_data.data(), params.user_data.size());
  }
  // Liveliness of the supervisor's setpoints: a leg controller that waits for a setpoint
  // (lockstep) stops waiting when the writer's process is gone. Offered by the writer only:
  // readers keep the default (infinite) request, so that they match any writer (a replay
  // tool's too) and still see the liveliness changes of a writer that offers a lease.
  if (kind == TopicKind::kLegSetpoint && writer) {
    dds_qset_liveliness(q, DDS_LIVELINESS_AUTOMATIC,
                        SecondsToDuration(params.setpoint_liveliness_lease_s));
    // A lost writer's instances become NOT_ALIVE_NO_WRITERS, not DISPOSED: only a supervisor
    // that ends the session disposes its setpoints (explicitly), and the legs tell the two apart.
    dds_qset_writer_data_lifecycle(q, false);
  }

  // Liveliness, ownership and instance lifecycle of the hot-standby valve command.
  if (kind == TopicKind::kValveCommand) {
    const dds_duration_t lease = SecondsToDuration(params.valve_liveliness_lease_s);
    if (writer) {
      dds_qset_liveliness(q,
                          params.valve_liveliness == LivelinessKind::kManualByTopic
                              ? DDS_LIVELINESS_MANUAL_BY_TOPIC
                              : DDS_LIVELINESS_AUTOMATIC,
                          lease);
      dds_qset_ownership_strength(q, params.ownership_strength);
      // A primary that exits cleanly unregisters its leg without disposing it, so the
      // instance stays alive and ownership passes to the standby.
      dds_qset_writer_data_lifecycle(q, false);
    } else if (recorder) {
      // The recorder must match every writer whatever lease it offers (requested >= offered).
      dds_qset_liveliness(q, DDS_LIVELINESS_AUTOMATIC, DDS_INFINITY);
    } else {
      dds_qset_liveliness(q, DDS_LIVELINESS_AUTOMATIC, lease);
    }
    // SHARED: every writer's samples reach every reader, and the plant chooses which leg
    // controller it applies (core/command_source.hpp) among the writers whose samples are
    // authenticated (command_auth.hpp). With EXCLUSIVE ownership a foreign writer of higher
    // strength would own the instance and hide the real controller's samples. The strength
    // stays in the writer's QoS as a description (primary 20, standby 10); it decides nothing.
    dds_qset_ownership(q, DDS_OWNERSHIP_SHARED);
  }
  return qos;
}

}  // namespace hexa::comm
