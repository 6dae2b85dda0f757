// The Foxglove WebSocket protocol (subprotocol "foxglove.websocket.v1") as far as hexa_bridge
// speaks it (docs/foxglove.md): the server sends serverInfo, advertise (protobuf channels with
// base64 FileDescriptorSet schemas), status, and binary Message Data frames; a client may send
// subscribe and unsubscribe. Anything else from a client is a protocol error. Pure functions:
// no sockets, no DDS.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace hexa::bridge {

inline constexpr const char* kSubprotocol = "foxglove.websocket.v1";

struct ChannelInfo {
  uint32_t id = 0;
  std::string topic;
  std::string schema_name;   // protobuf full name, e.g. "hexa.rec.LegSensors"
  std::string schema;        // serialized FileDescriptorSet (raw bytes; base64 on the wire)
};

enum class StatusLevel { kInfo = 0, kWarning = 1, kError = 2 };

std::string ServerInfoJson(const std::string& name, const std::string& session_id);
std::string AdvertiseJson(const std::vector<ChannelInfo>& channels);
std::string StatusJson(StatusLevel level, const std::string& message);

// Binary Message Data frame: opcode 0x01, uint32 subscription id, uint64 timestamp (ns), the
// payload; little-endian.
void MessageDataFrame(uint32_t subscription_id, uint64_t timestamp_ns, std::string_view payload,
                      std::string& out);

// A client's text message, checked. kind kError: `error` says what is wrong (the connection is
// then closed with a protocol error).
struct ClientRequest {
  enum class Kind { kSubscribe, kUnsubscribe, kError } kind = Kind::kError;
  std::vector<std::pair<uint32_t, uint32_t>> subscriptions;  // (subscription id, channel id)
  std::vector<uint32_t> unsubscribe_ids;
  std::string error;
};
ClientRequest ParseClientText(std::string_view text);

}  // namespace hexa::bridge
