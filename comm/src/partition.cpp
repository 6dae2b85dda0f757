#include "hexa/comm/partition.hpp"

#include "hexa/comm/error.hpp"
#include "hexa/comm/qos.hpp"

namespace hexa::comm {
namespace {

Qos PartitionQos(const std::vector<std::string>& partitions) {
  Qos qos;
  std::vector<const char*> names;
  names.reserve(partitions.size());
  for (const std::string& p : partitions) names.push_back(p.c_str());
  dds_qset_partition(qos.get(), static_cast<uint32_t>(names.size()), names.data());
  return qos;
}

std::string Describe(const std::vector<std::string>& partitions) {
  std::string text;
  for (const std::string& p : partitions) text += (text.empty() ? "" : ",") + p;
  return text;
}

}  // namespace

std::string LegPartition(int leg_id) { return "hexa.leg" + std::to_string(leg_id); }

std::vector<std::string> AllLegPartitions() {
  std::vector<std::string> all;
  for (int leg = 1; leg <= 6; ++leg) all.push_back(LegPartition(leg));
  return all;
}

OwnedEntity CreatePublisher(const Participant& participant,
                            const std::vector<std::string>& partitions) {
  if (partitions.empty()) return OwnedEntity();
  const Qos qos = PartitionQos(partitions);
  return OwnedEntity(CheckDds(dds_create_publisher(participant.get(), qos.get(), nullptr),
                              "cannot create publisher in partitions " + Describe(partitions)));
}

OwnedEntity CreateSubscriber(const Participant& participant,
                             const std::vector<std::string>& partitions) {
  if (partitions.empty()) return OwnedEntity();
  const Qos qos = PartitionQos(partitions);
  return OwnedEntity(CheckDds(dds_create_subscriber(participant.get(), qos.get(), nullptr),
                              "cannot create subscriber in partitions " + Describe(partitions)));
}

}  // namespace hexa::comm
