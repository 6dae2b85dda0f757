// In-process tests of the comm layer: QoS profiles, config-log parsing, reader/writer
// behaviour within one participant, waitset wake-ups. Domain ids 45-46.
#include <gtest/gtest.h>
#include <signal.h>

#include <chrono>
#include <cmath>
#include <limits>

#include "hexa/comm/comm.hpp"

namespace {

using namespace hexa::comm;

constexpr dds_domainid_t kDomainInProcess = 45;
constexpr dds_domainid_t kDomainShutdown = 46;

class CommUnit : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { EnsureDdsConfig(); }
};

TEST_F(CommUnit, QosProfilesMatchTheTopicTable) {
  // Writers of the periodic topics offer BEST_EFFORT in real time, RELIABLE in lockstep, and
  // the nominal deadline; LegSensors 1 ms, LegSetpoint 5 ms.
  {
    const Qos q = MakeQos(TopicKind::kLegSensors, EndpointRole::kWriter);
    dds_reliability_kind_t rel;
    dds_duration_t block;
    ASSERT_TRUE(dds_qget_reliability(q.get(), &rel, &block));
    EXPECT_EQ(rel, DDS_RELIABILITY_BEST_EFFORT);
    QosParams lockstep;
    lockstep.lockstep = true;
    const Qos l = MakeQos(TopicKind::kLegSensors, EndpointRole::kWriter, lockstep);
    ASSERT_TRUE(dds_qget_reliability(l.get(), &rel, &block));
    EXPECT_EQ(rel, DDS_RELIABILITY_RELIABLE);
    dds_duration_t deadline = 0;
    ASSERT_TRUE(dds_qget_deadline(q.get(), &deadline));
    EXPECT_EQ(deadline, DDS_MSECS(1));
    dds_history_kind_t hist;
    int32_t depth = 0;
    ASSERT_TRUE(dds_qget_history(q.get(), &hist, &depth));
    EXPECT_EQ(hist, DDS_HISTORY_KEEP_LAST);
    EXPECT_EQ(depth, 3000);  // 3 s at 1 kHz: what a stalled reliable reader can still get
  }
  {
    const Qos q = MakeQos(TopicKind::kLegSetpoint, EndpointRole::kControlReader);
    dds_duration_t deadline = 0;
    ASSERT_TRUE(dds_qget_deadline(q.get(), &deadline));
    EXPECT_EQ(deadline, DDS_MSECS(5));
    dds_reliability_kind_t rel;
    dds_duration_t block;
    ASSERT_TRUE(dds_qget_reliability(q.get(), &rel, &block));
    EXPECT_EQ(rel, DDS_RELIABILITY_BEST_EFFORT);  // real time: no head-of-line blocking
  }
  {
    QosParams lockstep;
    lockstep.lockstep = true;
    const Qos q = MakeQos(TopicKind::kLegSetpoint, EndpointRole::kControlReader, lockstep);
    dds_reliability_kind_t rel;
    dds_duration_t block;
    ASSERT_TRUE(dds_qget_reliability(q.get(), &rel, &block));
    EXPECT_EQ(rel, DDS_RELIABILITY_RELIABLE);  // lockstep must not lose a sample
    dds_history_kind_t hist;
    int32_t depth = 0;
    ASSERT_TRUE(dds_qget_history(q.get(), &hist, &depth));
    EXPECT_EQ(hist, DDS_HISTORY_KEEP_LAST);
    EXPECT_EQ(depth, 1);  // the default: the newest sample only
    lockstep.control_reader_depth = 64;  // a lockstep leg controller (hot standby may lag)
    const Qos deep = MakeQos(TopicKind::kLegSetpoint, EndpointRole::kControlReader, lockstep);
    ASSERT_TRUE(dds_qget_history(deep.get(), &hist, &depth));
    EXPECT_EQ(depth, 64);
    lockstep.control_reader_depth = 0;
    EXPECT_THROW(MakeQos(TopicKind::kLegSetpoint, EndpointRole::kControlReader, lockstep),
                 std::invalid_argument);
  }
  {
    // Valve command: shared (the reader picks primary or standby), strength (descriptive),
    // liveliness lease, no auto-dispose.
    QosParams standby;
    standby.ownership_strength = kStandbyOwnershipStrength;
    standby.valve_liveliness = LivelinessKind::kManualByTopic;
    const Qos q = MakeQos(TopicKind::kValveCommand, EndpointRole::kWriter, standby);
    dds_ownership_kind_t own;
    ASSERT_TRUE(dds_qget_ownership(q.get(), &own));
    EXPECT_EQ(own, DDS_OWNERSHIP_SHARED);
    int32_t strength = 0;
    ASSERT_TRUE(dds_qget_ownership_strength(q.get(), &strength));
    EXPECT_EQ(strength, 10);
    dds_liveliness_kind_t live;
    dds_duration_t lease = 0;
    ASSERT_TRUE(dds_qget_liveliness(q.get(), &live, &lease));
    EXPECT_EQ(live, DDS_LIVELINESS_MANUAL_BY_TOPIC);
    EXPECT_EQ(lease, DDS_MSECS(10));
    bool autodispose = true;
    ASSERT_TRUE(dds_qget_writer_data_lifecycle(q.get(), &autodispose));
    EXPECT_FALSE(autodispose);
  }
  {
    // The recorder matches a valve writer of any lease: it requests an infinite one.
    const Qos q = MakeQos(TopicKind::kValveCommand, EndpointRole::kRecorderReader);
    dds_liveliness_kind_t live;
    dds_duration_t lease = 0;
    ASSERT_TRUE(dds_qget_liveliness(q.get(), &live, &lease));
    EXPECT_EQ(lease, DDS_INFINITY);
    dds_ownership_kind_t own;
    ASSERT_TRUE(dds_qget_ownership(q.get(), &own));
    EXPECT_EQ(own, DDS_OWNERSHIP_SHARED);
  }
  {
    const Qos q = MakeQos(TopicKind::kNodeStatus, EndpointRole::kControlReader);
    dds_durability_kind_t dur;
    ASSERT_TRUE(dds_qget_durability(q.get(), &dur));
    EXPECT_EQ(dur, DDS_DURABILITY_TRANSIENT_LOCAL);
  }
  {
    const Qos q = MakeQos(TopicKind::kOperatorCommand, EndpointRole::kWriter);
    dds_history_kind_t hist;
    int32_t depth = 0;
    ASSERT_TRUE(dds_qget_history(q.get(), &hist, &depth));
    EXPECT_EQ(hist, DDS_HISTORY_KEEP_ALL);
  }
  {
    // The recorder requests no deadline, so it matches whatever period a writer offers.
    const Qos q = MakeQos(TopicKind::kGroundTruth, EndpointRole::kRecorderReader);
    dds_duration_t deadline = 0;
    EXPECT_FALSE(dds_qget_deadline(q.get(), &deadline) && deadline != DDS_INFINITY);
  }
}

// Real-time recorder (QosParams::recorder_periodic_best_effort): every periodic topic best
// effort, as the real-time writers offer it; the event topics stay reliable. Default
// (lockstep): reliable everywhere. Writers: periodic topics best effort in real time
// (Cyclone 0.10.2 loses the sample after every lost one for a best-effort reader of a
// reliable writer), reliable in lockstep; event topics reliable.
TEST_F(CommUnit, RealTimeRecorderReadsPeriodicTopicsBestEffort) {
  QosParams rt;
  rt.recorder_periodic_best_effort = true;
  QosParams lockstep;
  lockstep.lockstep = true;
  for (int k = 0; k < kTopicKindCount; ++k) {
    const auto kind = static_cast<TopicKind>(k);
    const auto periodic_rt = NominalPeriod_s(kind) ? DDS_RELIABILITY_BEST_EFFORT : DDS_RELIABILITY_RELIABLE;
    dds_reliability_kind_t rel;
    dds_duration_t blocking = 0;
    const Qos r = MakeQos(kind, EndpointRole::kRecorderReader, rt);
    ASSERT_TRUE(dds_qget_reliability(r.get(), &rel, &blocking));
    EXPECT_EQ(rel, periodic_rt) << TopicName(kind);
    const Qos d = MakeQos(kind, EndpointRole::kRecorderReader);
    ASSERT_TRUE(dds_qget_reliability(d.get(), &rel, &blocking));
    EXPECT_EQ(rel, DDS_RELIABILITY_RELIABLE) << TopicName(kind);
    const Qos w = MakeQos(kind, EndpointRole::kWriter, rt);
    ASSERT_TRUE(dds_qget_reliability(w.get(), &rel, &blocking));
    EXPECT_EQ(rel, periodic_rt) << TopicName(kind);
    const Qos wl = MakeQos(kind, EndpointRole::kWriter, lockstep);
    ASSERT_TRUE(dds_qget_reliability(wl.get(), &rel, &blocking));
    EXPECT_EQ(rel, DDS_RELIABILITY_RELIABLE) << TopicName(kind);
  }
}

// Every reader of a mode matches that mode's writers on reliability (a reliable request
// needs a reliable offer): real time (lockstep false, the recorder with
// recorder_periodic_best_effort) and lockstep (lockstep true, the recorder's default).
TEST_F(CommUnit, EveryReaderMatchesTheWritersOfItsModeOnReliability) {
  for (const bool lockstep : {false, true}) {
    QosParams p;
    p.lockstep = lockstep;
    p.recorder_periodic_best_effort = !lockstep;
    for (int k = 0; k < kTopicKindCount; ++k) {
      const auto kind = static_cast<TopicKind>(k);
      dds_reliability_kind_t offered, requested;
      dds_duration_t blocking = 0;
      const Qos w = MakeQos(kind, EndpointRole::kWriter, p);
      ASSERT_TRUE(dds_qget_reliability(w.get(), &offered, &blocking));
      for (const EndpointRole role : {EndpointRole::kControlReader, EndpointRole::kRecorderReader}) {
        const Qos r = MakeQos(kind, role, p);
        ASSERT_TRUE(dds_qget_reliability(r.get(), &requested, &blocking));
        EXPECT_TRUE(requested == DDS_RELIABILITY_BEST_EFFORT || offered == DDS_RELIABILITY_RELIABLE)
            << TopicName(kind) << (lockstep ? " lockstep" : " real time") << " role " << static_cast<int>(role);
      }
    }
  }
  // The mismatch the recorder must report (RecorderDds.ReliableRecorderReportsARealTimeWriter...):
  // a default (reliable) recorder reader against a real-time periodic writer.
  dds_reliability_kind_t offered, requested;
  dds_duration_t blocking = 0;
  ASSERT_TRUE(dds_qget_reliability(MakeQos(TopicKind::kLegSensors, EndpointRole::kWriter).get(), &offered, &blocking));
  ASSERT_TRUE(dds_qget_reliability(MakeQos(TopicKind::kLegSensors, EndpointRole::kRecorderReader).get(), &requested,
                                   &blocking));
  EXPECT_EQ(offered, DDS_RELIABILITY_BEST_EFFORT);
  EXPECT_EQ(requested, DDS_RELIABILITY_RELIABLE);
  EXPECT_EQ(QosPolicyName(DDS_RELIABILITY_QOS_POLICY_ID), "RELIABILITY");
  EXPECT_EQ(QosPolicyName(DDS_DEADLINE_QOS_POLICY_ID), "DEADLINE");
}

TEST_F(CommUnit, QosParamsValidateNamesTheField) {
  QosParams p;
  p.deadline_period_s = -0.001;
  try {
    p.Validate();
    FAIL() << "negative deadline accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("deadline_period_s"), std::string::npos);
  }
  QosParams q;
  q.valve_liveliness_lease_s = 0.0;
  EXPECT_THROW(q.Validate(), std::invalid_argument);
  QosParams r;
  r.deadline_period_s = std::numeric_limits<double>::infinity();
  EXPECT_NO_THROW(r.Validate());
  EXPECT_EQ(DeadlinePeriod_ns(TopicKind::kLegSensors, r), DDS_INFINITY);
}

TEST_F(CommUnit, NetworkLogParserAcceptsLoopbackAndRejectsEth0) {
  const char* loopback =
      "1.0 [40] p: interfaces: lo udp/127.0.0.1(q1) eth0 udp/192.0.2.2(q9)\n"
      "1.0 [40] p: assuming multicast capable interface lo.selected interfaces: lo (index 1 "
      "priority 2)\n"
      "1.0 [40] p: ownip: udp/127.0.0.1\n";
  const CycloneNetworkReport ok = ParseCycloneNetworkLog(loopback);
  std::string why;
  EXPECT_TRUE(IsLoopbackOnly(ok, &why)) << why;
  ASSERT_EQ(ok.selected_interfaces.size(), 1u);
  EXPECT_EQ(ok.selected_interfaces[0], "lo");

  // What an unpinned Cyclone reports: it picks eth0. Must be rejected.
  const char* eth0 =
      "1.0 [40] p: interfaces: lo udp/127.0.0.1(q1) eth0 udp/192.0.2.2(q9)\n"
      "1.0 [40] p: selected interfaces: eth0 (index 2 priority 0)\n"
      "1.0 [40] p: ownip: udp/192.0.2.2\n";
  EXPECT_FALSE(IsLoopbackOnly(ParseCycloneNetworkLog(eth0), &why));
  EXPECT_NE(why.find("eth0"), std::string::npos) << why;
  // Both interfaces selected is not loopback-only either.
  const char* both =
      "selected interfaces: lo (index 1 priority 2), eth0 (index 2 priority 0)\n"
      "ownip: udp/127.0.0.1\n";
  EXPECT_FALSE(IsLoopbackOnly(ParseCycloneNetworkLog(both), &why));
  // No log lines at all (tracing not enabled) proves nothing.
  EXPECT_FALSE(IsLoopbackOnly(ParseCycloneNetworkLog("nothing here\n"), &why));
}

TEST_F(CommUnit, ReaderTakesLatestPerLegAndFilteredTopicSeesOneLeg) {
  Participant p(kDomainInProcess);
  QosParams params;
  params.deadline_period_s = std::numeric_limits<double>::infinity();
  Topic<hexa_msg_LegSensors> topic(p);
  auto leg4_topic = Topic<hexa_msg_LegSensors>::FilteredByLeg(p, 4);
  Writer<hexa_msg_LegSensors> writer(p, topic, params);
  Reader<hexa_msg_LegSensors> reader(p, topic, EndpointRole::kControlReader, params);
  Reader<hexa_msg_LegSensors> leg4(p, leg4_topic, EndpointRole::kControlReader, params);

  hexa_msg_LegSensors out{};
  EXPECT_EQ(reader.TakeLatestForLeg(2, out), 0);  // nothing yet

  for (uint64_t tick = 1; tick <= 3; ++tick) {
    for (uint8_t leg = 1; leg <= 6; ++leg) {
      hexa_msg_LegSensors s{};
      s.leg_id = leg;
      FillHeader(s.header, tick, tick * 0.001, RealtimeNow_ns());
      s.length_m = leg * 0.1 + static_cast<double>(tick);
      ASSERT_EQ(writer.Write(s, s.header.source_time_ns), DDS_RETCODE_OK);
    }
  }
  // Local delivery is synchronous in Cyclone for a writer and reader of one participant.
  dds_sample_info_t info{};
  ASSERT_EQ(reader.TakeLatestForLeg(2, out, &info), 1);
  EXPECT_EQ(out.leg_id, 2);
  EXPECT_EQ(out.header.tick, 3u);  // keep-last 1: the newest
  EXPECT_EQ(info.source_timestamp, out.header.source_time_ns);
  EXPECT_EQ(reader.TakeLatestForLeg(2, out), 0);  // taken

  ASSERT_GT(leg4.Take(), 0);
  for (std::size_t i = 0; i < leg4.count(); ++i) EXPECT_EQ(leg4.sample(i).leg_id, 4);
  EXPECT_EQ(leg4.count(), 1u);  // one instance, keep-last 1
}

TEST_F(CommUnit, ReaderRequestingShorterDeadlineThanOfferedDoesNotMatch) {
  Participant p(kDomainInProcess);
  QosParams writer_params;
  writer_params.deadline_period_s = 0.100;
  QosParams reader_params;
  reader_params.deadline_period_s = 0.010;  // asks for more than the writer promises
  Topic<hexa_msg_ImuSample> topic(p);
  Writer<hexa_msg_ImuSample> writer(p, topic, writer_params);
  Reader<hexa_msg_ImuSample> reader(p, topic, EndpointRole::kControlReader, reader_params);
  Reader<hexa_msg_ImuSample> compatible(p, topic, EndpointRole::kControlReader, writer_params);
  hexa_msg_ImuSample s{};
  s.orientation_wxyz[0] = 1.0;
  ASSERT_EQ(writer.WriteNow(s), DDS_RETCODE_OK);
  EXPECT_EQ(reader.Take(), 0);
  EXPECT_GE(reader.Snapshot().requested_incompatible_qos_total, 1u);
  EXPECT_EQ(QosPolicyName(reader.Snapshot().requested_incompatible_qos_last_policy), "DEADLINE");
  EXPECT_EQ(compatible.Take(), 1);
  EXPECT_EQ(writer.Snapshot().publication_matched_current, 1u);
}

// A real-time periodic writer offers BEST_EFFORT: a recorder reader with the default
// (lockstep, reliable) QoS does not match it, and the reader's status names RELIABILITY (what
// hexa_recorder record reports); the real-time recorder QoS and a real-time control reader
// match and get the sample. A lockstep writer matches the reliable recorder reader.
TEST_F(CommUnit, ReliableReaderOfARealTimePeriodicWriterReportsReliability) {
  Participant p(kDomainInProcess);
  QosParams rt;  // lockstep false
  rt.deadline_period_s = std::numeric_limits<double>::infinity();
  QosParams rt_recorder = rt;
  rt_recorder.recorder_periodic_best_effort = true;
  Topic<hexa_msg_GroundTruth> topic(p);
  Writer<hexa_msg_GroundTruth> writer(p, topic, rt);
  Reader<hexa_msg_GroundTruth> reliable(p, topic, EndpointRole::kRecorderReader, rt);
  Reader<hexa_msg_GroundTruth> best_effort(p, topic, EndpointRole::kRecorderReader, rt_recorder);
  Reader<hexa_msg_GroundTruth> control(p, topic, EndpointRole::kControlReader, rt);
  hexa_msg_GroundTruth s{};
  FillHeader(s.header, 1, 0.001, RealtimeNow_ns());
  ASSERT_EQ(writer.Write(s, s.header.source_time_ns), DDS_RETCODE_OK);
  EXPECT_EQ(reliable.Take(), 0);
  EXPECT_EQ(reliable.Snapshot().requested_incompatible_qos_total, 1u);
  EXPECT_EQ(QosPolicyName(reliable.Snapshot().requested_incompatible_qos_last_policy), "RELIABILITY");
  EXPECT_EQ(reliable.Snapshot().requested_incompatible_qos_not_partition_total, 1u);
  // A partition mismatch (by design: the legs' partitions) is incompatible QoS to Cyclone too,
  // but not counted as "not partition".
  Reader<hexa_msg_GroundTruth> other_partition(p, topic, EndpointRole::kControlReader, rt, 16, {"hexa.elsewhere"});
  EXPECT_EQ(other_partition.Take(), 0);
  EXPECT_GE(other_partition.Snapshot().requested_incompatible_qos_total, 1u);
  EXPECT_EQ(QosPolicyName(other_partition.Snapshot().requested_incompatible_qos_last_policy), "PARTITION");
  EXPECT_EQ(other_partition.Snapshot().requested_incompatible_qos_not_partition_total, 0u);
  EXPECT_EQ(best_effort.Take(), 1);
  EXPECT_EQ(control.Take(), 1);
  EXPECT_EQ(writer.Snapshot().publication_matched_current, 2u);

  QosParams lockstep = rt;
  lockstep.lockstep = true;
  Writer<hexa_msg_GroundTruth> lockstep_writer(p, topic, lockstep);
  ASSERT_EQ(lockstep_writer.Write(s, s.header.source_time_ns), DDS_RETCODE_OK);
  EXPECT_EQ(reliable.Take(), 1);
  EXPECT_EQ(lockstep_writer.Snapshot().publication_matched_current, 3u);
}

// hexa_operator writes once the supervisor's OperatorCommand reader has matched, not once any
// reader has: a recorder's reader (no USER_DATA) matching first is not counted; the reader
// that carries kSupervisorCommandReader is (in process, matching is immediate).
TEST_F(CommUnit, OperatorWaitsForTheSupervisorsReaderNotAnyReader) {
  Participant p(kDomainInProcess);
  QosParams params;
  Topic<hexa_msg_OperatorCommand> topic(p);
  Writer<hexa_msg_OperatorCommand> writer(p, topic, params);
  Reader<hexa_msg_OperatorCommand> recorder(p, topic, EndpointRole::kRecorderReader, params);
  EXPECT_EQ(writer.Snapshot().publication_matched_current, 1u);
  EXPECT_EQ(CountMatchedReadersWithUserData(writer.get(), kSupervisorCommandReader), 0);
  QosParams supervisor_params = params;
  supervisor_params.user_data = kSupervisorCommandReader;
  {
    Reader<hexa_msg_OperatorCommand> supervisor(p, topic, EndpointRole::kControlReader, supervisor_params);
    EXPECT_EQ(writer.Snapshot().publication_matched_current, 2u);
    EXPECT_EQ(CountMatchedReadersWithUserData(writer.get(), kSupervisorCommandReader), 1);
    EXPECT_EQ(CountMatchedReadersWithUserData(writer.get(), "role=other"), 0);
  }
  EXPECT_EQ(CountMatchedReadersWithUserData(writer.get(), kSupervisorCommandReader), 0);  // gone
}

// The supervisor starts once every leg's PRIMARY reads its setpoints: a hot standby's reader
// (the same leg, standby=1) does not count for the primary.
TEST_F(CommUnit, SetpointReadersSayWhichLegAndWhetherStandby) {
  Participant p(kDomainInProcess);
  QosParams params;
  Topic<hexa_msg_LegSetpoint> topic(p);
  Writer<hexa_msg_LegSetpoint> writer(p, topic, params);
  EXPECT_EQ(LegEndpointUserData(4, false), "leg=4 standby=0");
  int leg = 0;
  bool is_standby = false;
  ASSERT_TRUE(ParseLegEndpointUserData(LegEndpointUserData(6, true), leg, is_standby));
  EXPECT_EQ(leg, 6);
  EXPECT_TRUE(is_standby);
  EXPECT_FALSE(ParseLegEndpointUserData("role=supervisor", leg, is_standby));
  EXPECT_FALSE(ParseLegEndpointUserData("leg=0 standby=0", leg, is_standby));
  QosParams standby = params;
  standby.user_data = LegEndpointUserData(4, true);
  Reader<hexa_msg_LegSetpoint> standby_reader(p, topic, EndpointRole::kControlReader, standby);
  EXPECT_EQ(writer.Snapshot().publication_matched_current, 1u);
  EXPECT_EQ(CountMatchedReadersWithUserData(writer.get(), LegEndpointUserData(4, false)), 0);
  QosParams primary = params;
  primary.user_data = LegEndpointUserData(4, false);
  Reader<hexa_msg_LegSetpoint> primary_reader(p, topic, EndpointRole::kControlReader, primary);
  EXPECT_EQ(CountMatchedReadersWithUserData(writer.get(), LegEndpointUserData(4, false)), 1);
  EXPECT_EQ(CountMatchedReadersWithUserData(writer.get(), LegEndpointUserData(5, false)), 0);
}

TEST_F(CommUnit, GuardConditionWakesWaitSet) {
  Participant p(kDomainInProcess);
  GuardCondition guard(p);
  WaitSet ws(p);
  ws.Attach(guard.get(), 7);
  EXPECT_EQ(ws.Wait(DDS_MSECS(1)), 0);  // nothing triggered: timeout
  guard.Set();
  ASSERT_EQ(ws.Wait(DDS_SECS(5)), 1);
  EXPECT_TRUE(ws.Triggered(7));
}

TEST_F(CommUnit, ShutdownGuardTurnsSigtermIntoGuardCondition) {
  Participant p(kDomainShutdown);
  ShutdownGuard guard(p);
  EXPECT_THROW(ShutdownGuard second(p), std::runtime_error);
  WaitSet ws(p);
  ws.Attach(guard.guard_condition(), 1);
  EXPECT_FALSE(guard.requested());
  ASSERT_EQ(raise(SIGTERM), 0);  // handled: the process goes on
  ASSERT_EQ(ws.Wait(DDS_SECS(5)), 1);
  EXPECT_TRUE(ws.Triggered(1));
  EXPECT_TRUE(guard.requested());
  EXPECT_EQ(guard.signal_number(), SIGTERM);
}

TEST_F(CommUnit, ParticipantOnInvalidDomainFailsWithClearMessage) {
  try {
    Participant p(static_cast<dds_domainid_t>(300));  // above Cyclone's 232 limit
    FAIL() << "participant on domain 300 was created";
  } catch (const DdsError& e) {
    EXPECT_NE(std::string(e.what()).find("domain 300"), std::string::npos) << e.what();
  }
}

}  // namespace
