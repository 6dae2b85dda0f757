// The Foxglove WebSocket protocol (subprotocol "foxglove.websocket.v1") as far as hexa_bridge
// speaks it (docs/foxglove.md): the server sends serverInfo, advertise (protobuf channels with
// base64 FileDescriptorSet schemas), status, and binary Message Data frames; a client may send
// subscribe and unsubscribe, and with the clientPublish capability (operator input) advertise,
// unadvertise and binary Client Message Data. Anything else from a client is a protocol error.
// Pure functions: no sockets, no DDS.
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

// client_publish: advertise the clientPublish capability (JSON-encoded client channels).
std::string ServerInfoJson(const std::string& name, const std::string& session_id,
                           bool client_publish = false);
std::string AdvertiseJson(const std::vector<ChannelInfo>& channels);
std::string StatusJson(StatusLevel level, const std::string& message);

// Binary Message Data frame: opcode 0x01, uint32 subscription id, uint64 timestamp (ns), the
// payload; little-endian.
void MessageDataFrame(uint32_t subscription_id, uint64_t timestamp_ns, std::string_view payload,
                      std::string& out);

// A client's text message, checked. kind kError: `error` says what is wrong (the connection is
// then closed with a protocol error).
struct ClientChannel {
  uint32_t id = 0;
  std::string topic, encoding, schema_name;
};
struct ClientRequest {
  enum class Kind { kSubscribe, kUnsubscribe, kAdvertise, kUnadvertise, kError } kind = Kind::kError;
  std::vector<std::pair<uint32_t, uint32_t>> subscriptions;  // (subscription id, channel id)
  std::vector<uint32_t> unsubscribe_ids;
  std::vector<ClientChannel> channels;      // advertise
  std::vector<uint32_t> unadvertise_ids;    // unadvertise
  std::string error;
};
// client_publish: whether advertise / unadvertise are accepted (else unsupported ops).
ClientRequest ParseClientText(std::string_view text, bool client_publish = false);

// A client's binary Client Message Data frame: opcode 0x01, uint32 channel id, the payload.
struct ClientMessageData {
  bool ok = false;
  uint32_t channel_id = 0;
  std::string_view payload;
  std::string error;
};
ClientMessageData ParseClientBinary(std::string_view frame);

}  // namespace hexa::bridge
