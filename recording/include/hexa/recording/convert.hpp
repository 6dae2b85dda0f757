// DDS wire types (idl/hexa.idl, generated C structs) <-> recording protobuf messages
// (proto/recording.proto). This is the ONLY place where the two are mapped.
//
// ToProto never fails. FromProto returns false (and leaves `out` partly written) when the
// protobuf message cannot be represented on the wire: a repeated field with the wrong count,
// a string longer than its IDL bound, an id outside the IDL integer range, an unknown enum.
#pragma once

#include <google/protobuf/message.h>

#include <cstddef>
#include <string_view>
#include <vector>

#include "hexa.h"
#include "recording.pb.h"

namespace hexa::recorder {

void ToProto(const hexa_msg_SampleHeader& in, rec::SampleHeader& out);
void ToProto(const hexa_msg_LegSensors& in, rec::LegSensors& out);
void ToProto(const hexa_msg_ValveCommand& in, rec::ValveCommand& out);
void ToProto(const hexa_msg_ImuSample& in, rec::ImuSample& out);
void ToProto(const hexa_msg_LegSetpoint& in, rec::LegSetpoint& out);
void ToProto(const hexa_msg_PoseReport& in, rec::PoseReport& out);
void ToProto(const hexa_msg_GroundTruth& in, rec::GroundTruth& out);
void ToProto(const hexa_msg_TrackerPose& in, rec::TrackerPose& out);
void ToProto(const hexa_msg_OperatorCommand& in, rec::OperatorCommand& out);
void ToProto(const hexa_msg_NodeStatus& in, rec::NodeStatus& out);
void ToProto(const hexa_msg_FaultEvent& in, rec::FaultEvent& out);

bool FromProto(const rec::SampleHeader& in, hexa_msg_SampleHeader& out);
bool FromProto(const rec::LegSensors& in, hexa_msg_LegSensors& out);
bool FromProto(const rec::ValveCommand& in, hexa_msg_ValveCommand& out);
bool FromProto(const rec::ImuSample& in, hexa_msg_ImuSample& out);
bool FromProto(const rec::LegSetpoint& in, hexa_msg_LegSetpoint& out);
bool FromProto(const rec::PoseReport& in, hexa_msg_PoseReport& out);
bool FromProto(const rec::GroundTruth& in, hexa_msg_GroundTruth& out);
bool FromProto(const rec::TrackerPose& in, hexa_msg_TrackerPose& out);
bool FromProto(const rec::OperatorCommand& in, hexa_msg_OperatorCommand& out);
bool FromProto(const rec::NodeStatus& in, hexa_msg_NodeStatus& out);
bool FromProto(const rec::FaultEvent& in, hexa_msg_FaultEvent& out);

// Type-erased view of one wire type, for code that handles every topic alike (record, play).
struct WireType {
  std::string_view name;                          // "LegSensors"
  const dds_topic_descriptor_t* dds_descriptor;   // &hexa_msg_LegSensors_desc
  size_t sample_size;                             // sizeof(hexa_msg_LegSensors)
  const google::protobuf::Message* prototype;     // &rec::LegSensors::default_instance()
  void (*to_proto)(const void* sample, google::protobuf::Message& out);
  bool (*from_proto)(const google::protobuf::Message& in, void* sample);
};

// Every wire type of hexa.idl that is published on a topic (SampleHeader is not).
const std::vector<WireType>& WireTypes();
// nullptr when unknown. Accepts "LegSensors" or the protobuf full name "hexa.rec.LegSensors".
const WireType* FindWireType(std::string_view name);

}  // namespace hexa::recorder
