// The one list of topic types (recording/include/hexa/recording/topic_types.hpp) against the
// comm layer's topic kinds: every kind once, each with its own DDS descriptor and the
// recording message of the same name; WireTypes() lists the same types in the same order.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "hexa/comm/qos.hpp"
#include "hexa/comm/topic.hpp"
#include "hexa/recording/convert.hpp"
#include "hexa/recording/topic_types.hpp"

namespace hexa::recorder {
namespace {

TEST(TopicTypes, EveryTopicKindOnceWithItsDescriptorAndMessage) {
  std::vector<int> seen(comm::kTopicKindCount, 0);
  std::vector<std::string> names;
  ForEachTopicType([&](auto type) {
    using Type = decltype(type);
    using Traits = comm::TopicTraits<typename Type::Dds>;
    const int kind = static_cast<int>(Traits::kKind);
    ASSERT_GE(kind, 0);
    ASSERT_LT(kind, comm::kTopicKindCount);
    ++seen[static_cast<std::size_t>(kind)];
    EXPECT_EQ(Type::descriptor(), Traits::Descriptor());
    // "hexa::msg::LegSensors" on the wire, "hexa.rec.LegSensors" in the recording.
    const std::string dds_name = Type::descriptor()->m_typename;
    const std::string message = Type::Proto::descriptor()->name();
    EXPECT_EQ(dds_name, "hexa::msg::" + message);
    EXPECT_EQ(comm::TopicName(Traits::kKind), "hexa_" + message);
    names.push_back(message);
  });
  for (int k = 0; k < comm::kTopicKindCount; ++k)
    EXPECT_EQ(seen[static_cast<std::size_t>(k)], 1)
        << "topic kind " << k << " (" << comm::TopicName(static_cast<comm::TopicKind>(k)) << ")";
  ASSERT_EQ(WireTypes().size(), names.size());
  for (std::size_t i = 0; i < names.size(); ++i) EXPECT_EQ(WireTypes()[i].name, names[i]);
}

}  // namespace
}  // namespace hexa::recorder
