// The one list of the topic types: every wire type of idl/hexa.idl that is published on a
// topic, with its recording message (proto/recording.proto) and its DDS type descriptor.
// The recorder (record, play), the bridge, WireTypes() (convert.hpp) and the tests iterate
// over it; a new topic type is added here and nowhere else.
#pragma once

#include "hexa.h"
#include "recording.pb.h"

namespace hexa::recorder {

template <typename DdsMsg, typename ProtoMsg, const dds_topic_descriptor_t* kDescriptor>
struct TopicType {
  using Dds = DdsMsg;
  using Proto = ProtoMsg;
  static const dds_topic_descriptor_t* descriptor() { return kDescriptor; }
};

// Calls f(TopicType<...>{}) once per topic type, always in this order (WireTypes()'s order).
template <typename F>
void ForEachTopicType(F&& f) {
  f(TopicType<hexa_msg_LegSensors, rec::LegSensors, &hexa_msg_LegSensors_desc>{});
  f(TopicType<hexa_msg_ValveCommand, rec::ValveCommand, &hexa_msg_ValveCommand_desc>{});
  f(TopicType<hexa_msg_ImuSample, rec::ImuSample, &hexa_msg_ImuSample_desc>{});
  f(TopicType<hexa_msg_LegSetpoint, rec::LegSetpoint, &hexa_msg_LegSetpoint_desc>{});
  f(TopicType<hexa_msg_PoseReport, rec::PoseReport, &hexa_msg_PoseReport_desc>{});
  f(TopicType<hexa_msg_GroundTruth, rec::GroundTruth, &hexa_msg_GroundTruth_desc>{});
  f(TopicType<hexa_msg_TrackerPose, rec::TrackerPose, &hexa_msg_TrackerPose_desc>{});
  f(TopicType<hexa_msg_OperatorCommand, rec::OperatorCommand, &hexa_msg_OperatorCommand_desc>{});
  f(TopicType<hexa_msg_NodeStatus, rec::NodeStatus, &hexa_msg_NodeStatus_desc>{});
  f(TopicType<hexa_msg_FaultEvent, rec::FaultEvent, &hexa_msg_FaultEvent_desc>{});
}

}  // namespace hexa::recorder
