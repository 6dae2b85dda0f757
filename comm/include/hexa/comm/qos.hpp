// Named QoS profiles: the one place where every topic of idl/hexa.idl gets its name, its
// reliability, history, durability, deadline, liveliness and ownership (docs/comm.md has the
// table and the reasoning per topic). Writers and readers of a topic take their QoS from
// MakeQos(kind, role, params) so that what a writer offers and what a reader requests are
// compatible by construction (e.g. a reader requesting a deadline only matches a writer that
// offers one at least as short; docs/platform_notes.md).
#pragma once

#include <dds/dds.h>

#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <string_view>

namespace hexa::comm {

enum class TopicKind : uint8_t {
  kLegSensors,
  kValveCommand,
  kImuSample,
  kLegSetpoint,
  kPoseReport,
  kGroundTruth,
  kOperatorCommand,
  kNodeStatus,
  kFaultEvent,
  kTrackerPose,  // external pose instrument, calibration only
};
inline constexpr int kTopicKindCount = 10;

// Topic names on the wire (the DDS topic name; the type name comes from the IDL).
inline constexpr std::string_view kLegSensorsTopic = "hexa_LegSensors";
inline constexpr std::string_view kValveCommandTopic = "hexa_ValveCommand";
inline constexpr std::string_view kImuSampleTopic = "hexa_ImuSample";
inline constexpr std::string_view kLegSetpointTopic = "hexa_LegSetpoint";
inline constexpr std::string_view kPoseReportTopic = "hexa_PoseReport";
inline constexpr std::string_view kGroundTruthTopic = "hexa_GroundTruth";
inline constexpr std::string_view kOperatorCommandTopic = "hexa_OperatorCommand";
inline constexpr std::string_view kNodeStatusTopic = "hexa_NodeStatus";
inline constexpr std::string_view kFaultEventTopic = "hexa_FaultEvent";
inline constexpr std::string_view kTrackerPoseTopic = "hexa_TrackerPose";

std::string_view TopicName(TopicKind kind);

// Nominal period of a periodic topic (docs/design.md "Topics and QoS"); nullopt for event topics.
std::optional<double> NominalPeriod_s(TopicKind kind);

// Who uses the QoS. Readers differ by purpose: a control reader wants the newest sample with
// the least latency, the recorder wants every sample.
enum class EndpointRole : uint8_t {
  kWriter,          // periodic topics: BEST_EFFORT in real time, RELIABLE in lockstep
                    // (QosParams::lockstep); event topics RELIABLE
  kControlReader,   // leg_ctrl, task_space, plant: newest sample (keep-last 1 per instance)
  kRecorderReader,  // recorder: keep-all, historic data for transient-local topics; reliable
                    // unless QosParams::recorder_periodic_best_effort (real time)
};

enum class LivelinessKind : uint8_t { kAutomatic, kManualByTopic };

// Ownership strengths of the hot-standby scheme, offered for description only: ValveCommand is
// SHARED and the plant picks the primary or the standby itself (core/command_source.hpp).
inline constexpr int32_t kPrimaryOwnershipStrength = 20;
// USER_DATA of the supervisor's OperatorCommand reader: hexa_operator writes once a reader
// with it has matched (a recorder's reader matching first is not the supervisor's).
inline constexpr const char* kSupervisorCommandReader = "role=supervisor";
// USER_DATA of a leg controller's ValveCommand writer and LegSetpoint reader: which leg, and
// whether primary or hot standby ("leg=3 standby=0"). The plant reads it on the writers, the
// supervisor on the readers (it starts only when every leg's primary reads its setpoints).
inline std::string LegEndpointUserData(int leg, bool standby) {
  return "leg=" + std::to_string(leg) + " standby=" + (standby ? "1" : "0");
}
// The inverse: "leg=3 standby=1" -> leg 3, standby; false for anything else (leg < 1 too).
bool ParseLegEndpointUserData(const std::string& text, int& leg, bool& standby);
inline constexpr int32_t kStandbyOwnershipStrength = 10;

struct QosParams {
  // Deadline period of the topic. nullopt: the topic's nominal period (1 ms or 5 ms), used
  // in real time. Lockstep runs and tests on this VM (ms-level scheduling jitter,
  // docs/platform_notes.md) pass a longer one; +infinity disables the deadline. Writers and
  // readers of one topic must use the same value (the reader's must be >= the writer's).
  std::optional<double> deadline_period_s;
  // ValveCommand only: how the writer shows it is alive, and the lease. MANUAL_BY_TOPIC also
  // catches a hung control thread (Cyclone's own threads keep AUTOMATIC alive); it needs a
  // write or AssertLiveliness() at least once per lease. Readers always request AUTOMATIC
  // with the same lease, which is compatible with either kind the writer offers.
  LivelinessKind valve_liveliness = LivelinessKind::kAutomatic;
  double valve_liveliness_lease_s = 0.010;
  // LegSetpoint: AUTOMATIC liveliness lease of the supervisor's writer (infinite = none). A
  // leg controller learns from it that the supervisor's process is gone (docs/faults.md).
  double setpoint_liveliness_lease_s = std::numeric_limits<double>::infinity();
  // USER_DATA QoS of the endpoint, readable by every matched peer: the ValveCommand writers
  // say which leg they drive ("leg=3 standby=0"; docs/faults.md), the supervisor's
  // OperatorCommand reader says it is the supervisor's (kSupervisorCommandReader: hexa_operator
  // waits for that reader, not for any). Empty = none.
  std::string user_data;
  // ValveCommand writer only: ownership strength (primary 20, standby 10), descriptive.
  int32_t ownership_strength = kPrimaryOwnershipStrength;
  // Writers and control readers of the periodic topics: lockstep needs every sample (a lost
  // one would stall the tick), so both are RELIABLE; in real time both are BEST_EFFORT: no
  // head-of-line blocking behind a repair, the next sample supersedes a lost one 1 ms later,
  // and no writer keeps or resends anything for any reader. A reader that requests RELIABLE
  // (a lockstep reader, a recorder without recorder_periodic_best_effort) does not match a
  // real-time periodic writer (REQUESTED_INCOMPATIBLE_QOS, policy RELIABILITY).
  bool lockstep = false;
  // Control readers: keep-last depth per instance. 1 = the newest sample only (real time:
  // an older sample is worthless). A lockstep leg controller asks for more so that a hot
  // standby, which the plant does not wait for, can lag and still see every tick in order.
  int32_t control_reader_depth = 1;
  // Recorder readers only: request BEST_EFFORT for the periodic topics (LegSensors, ValveCommand,
  // GroundTruth, ImuSample, LegSetpoint, PoseReport, TrackerPose), as the real-time control readers
  // do. A reliable recorder reader makes every control writer of those topics repair what the
  // recorder's link dropped: acknowledgements, retransmission bursts out of up to 3 s of history,
  // on the writers' receive threads, which in real time run at the control loop's priority on the
  // control CPU. A 5 % lossy recorder link sent a real-time session to HOLD that way
  // (docs/measurements/deployment_recorder_link.md, "The lossy recorder link"). Best effort, no
  // recorder can cost a control writer anything: a sample dropped on the recorder's link is missing
  // in the recording (counted by tick). Lockstep keeps it false: the lockstep plant waits for the
  // recorder's acknowledgements and nothing may be lost.
  bool recorder_periodic_best_effort = false;

  // Throws std::invalid_argument naming the field, value and limit.
  void Validate() const;
};

// Owning handle of a dds_qos_t (dds_create_qos / dds_delete_qos).
class Qos {
 public:
  Qos();
  ~Qos();
  Qos(Qos&& other) noexcept;
  Qos& operator=(Qos&& other) noexcept;
  Qos(const Qos&) = delete;
  Qos& operator=(const Qos&) = delete;
  dds_qos_t* get() const { return qos_; }

 private:
  dds_qos_t* qos_;
};

// The QoS of `kind` for `role`. Validates params (throws std::invalid_argument).
Qos MakeQos(TopicKind kind, EndpointRole role, const QosParams& params = {});

// Name of a DDS QoS policy id (dds_qos_policy_id_t, e.g. DDS_RELIABILITY_QOS_POLICY_ID ->
// "RELIABILITY"), for the incompatible-QoS status (StatusSnapshot's last policy); "policy N"
// for one not named here.
std::string QosPolicyName(uint32_t policy_id);

// The QoS given to the topic entity itself (role-independent parts).
Qos MakeTopicQos(TopicKind kind);

// Effective deadline of `kind` under params, in ns; DDS_INFINITY for none.
dds_duration_t DeadlinePeriod_ns(TopicKind kind, const QosParams& params);

// Writer history depth per instance: the window over which a reliable reader (recorder,
// lockstep) can still have a lost sample repaired without the writer ever blocking.
int32_t WriterHistoryDepth(TopicKind kind);

}  // namespace hexa::comm
