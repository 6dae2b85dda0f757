// Topic<T>: a DDS topic of one generated wire type, named and configured from the named
// profiles in qos.hpp. TopicTraits<T> ties each generated C type of idl/hexa.idl to its
// descriptor and its TopicKind, so a service writes Topic<hexa_msg_LegSensors> and cannot
// pair a type with the wrong name or QoS.
#pragma once

#include <dds/dds.h>

#include <concepts>
#include <cstdint>
#include <string>

#include "hexa.h"
#include "hexa/comm/error.hpp"
#include "hexa/comm/participant.hpp"
#include "hexa/comm/qos.hpp"

namespace hexa::comm {

template <typename T>
struct TopicTraits;  // specialised for every type of idl/hexa.idl below

#define HEXA_COMM_TOPIC_TRAITS(Type, Kind, KeyedByLeg)                          \
  template <>                                                                   \
  struct TopicTraits<Type> {                                                    \
    static constexpr TopicKind kKind = TopicKind::Kind;                         \
    static constexpr bool kKeyedByLeg = KeyedByLeg;                             \
    static const dds_topic_descriptor_t* Descriptor() { return &Type##_desc; } \
  }

HEXA_COMM_TOPIC_TRAITS(hexa_msg_LegSensors, kLegSensors, true);
HEXA_COMM_TOPIC_TRAITS(hexa_msg_ValveCommand, kValveCommand, true);
HEXA_COMM_TOPIC_TRAITS(hexa_msg_ImuSample, kImuSample, false);
HEXA_COMM_TOPIC_TRAITS(hexa_msg_LegSetpoint, kLegSetpoint, true);
HEXA_COMM_TOPIC_TRAITS(hexa_msg_PoseReport, kPoseReport, false);
HEXA_COMM_TOPIC_TRAITS(hexa_msg_GroundTruth, kGroundTruth, false);
HEXA_COMM_TOPIC_TRAITS(hexa_msg_OperatorCommand, kOperatorCommand, false);
HEXA_COMM_TOPIC_TRAITS(hexa_msg_NodeStatus, kNodeStatus, false);
HEXA_COMM_TOPIC_TRAITS(hexa_msg_FaultEvent, kFaultEvent, false);
HEXA_COMM_TOPIC_TRAITS(hexa_msg_TrackerPose, kTrackerPose, false);
#undef HEXA_COMM_TOPIC_TRAITS

// A generated type this layer knows.
template <typename T>
concept WireType = requires {
  { TopicTraits<T>::kKind } -> std::convertible_to<TopicKind>;
};

// A type whose key is the leg id (1..6): LegSensors, ValveCommand, LegSetpoint.
template <typename T>
concept LegKeyed = WireType<T> && TopicTraits<T>::kKeyedByLeg && requires(const T& t) {
  { t.leg_id } -> std::convertible_to<uint8_t>;
};

template <WireType T>
class Topic {
 public:
  static constexpr TopicKind kKind = TopicTraits<T>::kKind;

  explicit Topic(const Participant& participant) : Topic(participant, 0) {}

  // A topic entity whose readers only receive leg `leg_id`'s samples (Cyclone topic filter,
  // applied on receipt before the reader cache): a leg controller then wakes only for its own
  // leg, and its deadline counts only that leg. Create one per filtered reader.
  static Topic FilteredByLeg(const Participant& participant, uint8_t leg_id)
    requires LegKeyed<T>
  {
    return Topic(participant, leg_id);
  }

  dds_entity_t get() const { return entity_.get(); }
  uint8_t leg_filter() const { return leg_filter_; }  // 0 = none

 private:
  Topic(const Participant& participant, uint8_t leg_filter) : leg_filter_(leg_filter) {
    const Qos qos = MakeTopicQos(kKind);
    const std::string name(TopicName(kKind));
    entity_ = OwnedEntity(CheckDds(
        dds_create_topic(participant.get(), TopicTraits<T>::Descriptor(), name.c_str(),
                         qos.get(), nullptr),
        "cannot create topic " + name + " on domain " + std::to_string(participant.domain_id())));
    if constexpr (LegKeyed<T>) {
      if (leg_filter != 0) {
        dds_topic_filter filter{};
        filter.mode = DDS_TOPIC_FILTER_SAMPLE_ARG;
        filter.f.sample_arg = &LegFilter;
        // The leg id travels in the pointer itself: nothing to keep alive or free.
        filter.arg = reinterpret_cast<void*>(static_cast<uintptr_t>(leg_filter));
        CheckDds(dds_set_topic_filter_extended(entity_.get(), &filter),
                 "cannot set leg filter on topic " + name);
      }
    }
  }

  static bool LegFilter(const void* sample, void* arg) {
    if constexpr (LegKeyed<T>) {
      return static_cast<const T*>(sample)->leg_id ==
             static_cast<uint8_t>(reinterpret_cast<uintptr_t>(arg));
    } else {
      return true;
    }
  }

  OwnedEntity entity_;
  uint8_t leg_filter_ = 0;
};

}  // namespace hexa::comm
