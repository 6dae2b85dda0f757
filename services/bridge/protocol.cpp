#include "protocol.hpp"

#include <cstring>

#include <nlohmann/json.hpp>
#include <websocketpp/base64/base64.hpp>

namespace hexa::bridge {
namespace {
using nlohmann::json;

// A non-negative integer that fits uint32 (ids on the wire are JSON numbers).
bool AsU32(const json& v, uint32_t& out) {
  if (!v.is_number_integer() && !v.is_number_unsigned()) return false;
  if (v.is_number_unsigned()) {
    const auto u = v.get<uint64_t>();
    if (u > UINT32_MAX) return false;
    out = static_cast<uint32_t>(u);
    return true;
  }
  const auto i = v.get<int64_t>();
  if (i < 0 || i > static_cast<int64_t>(UINT32_MAX)) return false;
  out = static_cast<uint32_t>(i);
  return true;
}

ClientRequest Error(std::string what) {
  ClientRequest r;
  r.kind = ClientRequest::Kind::kError;
  r.error = std::move(what);
  return r;
}
}  // namespace

std::string ServerInfoJson(const std::string& name, const std::string& session_id,
                           bool client_publish) {
  json j;
  j["op"] = "serverInfo";
  j["name"] = name;
  j["capabilities"] = client_publish ? json::array({"clientPublish"}) : json::array();
  j["supportedEncodings"] = client_publish ? json::array({"json"}) : json::array();
  j["metadata"] = json::object();
  j["sessionId"] = session_id;
  return j.dump();
}

std::string AdvertiseJson(const std::vector<ChannelInfo>& channels) {
  json list = json::array();
  for (const auto& c : channels) {
    list.push_back({{"id", c.id},
                    {"topic", c.topic},
                    {"encoding", "protobuf"},
                    {"schemaName", c.schema_name},
                    {"schema", websocketpp::base64_encode(c.schema)},
                    {"schemaEncoding", "protobuf"}});
  }
  return json{{"op", "advertise"}, {"channels", list}}.dump();
}

std::string StatusJson(StatusLevel level, const std::string& message) {
  // error_handler_t::replace: a message quoting bad client bytes stays valid JSON / UTF-8.
  return json{{"op", "status"}, {"level", static_cast<int>(level)}, {"message", message}}
      .dump(-1, ' ', false, json::error_handler_t::replace);
}

void MessageDataFrame(uint32_t subscription_id, uint64_t timestamp_ns, std::string_view payload,
                      std::string& out) {
  static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "the protocol is little-endian");
  out.resize(13 + payload.size());
  out[0] = 0x01;
  std::memcpy(out.data() + 1, &subscription_id, 4);
  std::memcpy(out.data() + 5, &timestamp_ns, 8);
  std::memcpy(out.data() + 13, payload.data(), payload.size());
}

ClientRequest ParseClientText(std::string_view text, bool client_publish) {
  const json j = json::parse(text.begin(), text.end(), nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded()) return Error("message is not valid JSON");
  if (!j.is_object()) return Error("message is not a JSON object");
  const auto op = j.find("op");
  if (op == j.end() || !op->is_string()) return Error("message has no string field 'op'");
  const std::string name = op->get<std::string>();
  ClientRequest r;
  if (name == "subscribe") {
    const auto subs = j.find("subscriptions");
    if (subs == j.end() || !subs->is_array())
      return Error("subscribe: 'subscriptions' must be an array");
    for (const auto& s : *subs) {
      uint32_t id = 0, channel = 0;
      if (!s.is_object() || !s.contains("id") || !s.contains("channelId") ||
          !AsU32(s["id"], id) || !AsU32(s["channelId"], channel))
        return Error("subscribe: each subscription needs integer 'id' and 'channelId' in "
                     "[0, 2^32)");
      r.subscriptions.emplace_back(id, channel);
    }
    r.kind = ClientRequest::Kind::kSubscribe;
    return r;
  }
  if (name == "unsubscribe") {
    const auto ids = j.find("subscriptionIds");
    if (ids == j.end() || !ids->is_array())
      return Error("unsubscribe: 'subscriptionIds' must be an array");
    for (const auto& v : *ids) {
      uint32_t id = 0;
      if (!AsU32(v, id)) return Error("unsubscribe: subscription ids must be integers in [0, 2^32)");
      r.unsubscribe_ids.push_back(id);
    }
    r.kind = ClientRequest::Kind::kUnsubscribe;
    return r;
  }
  if (client_publish && name == "advertise") {
    const auto chs = j.find("channels");
    if (chs == j.end() || !chs->is_array()) return Error("advertise: 'channels' must be an array");
    for (const auto& c : *chs) {
      ClientChannel ch;
      if (!c.is_object() || !c.contains("id") || !AsU32(c["id"], ch.id))
        return Error("advertise: each channel needs an integer 'id' in [0, 2^32)");
      for (auto [key, field] : {std::pair{"topic", &ch.topic}, std::pair{"encoding", &ch.encoding},
                                std::pair{"schemaName", &ch.schema_name}}) {
        if (!c.contains(key) || !c[key].is_string())
          return Error(std::string("advertise: each channel needs a string '") + key + "'");
        *field = c[key].get<std::string>();
      }
      r.channels.push_back(std::move(ch));
    }
    r.kind = ClientRequest::Kind::kAdvertise;
    return r;
  }
  if (client_publish && name == "unadvertise") {
    const auto ids = j.find("channelIds");
    if (ids == j.end() || !ids->is_array())
      return Error("unadvertise: 'channelIds' must be an array");
    for (const auto& v : *ids) {
      uint32_t id = 0;
      if (!AsU32(v, id)) return Error("unadvertise: channel ids must be integers in [0, 2^32)");
      r.unadvertise_ids.push_back(id);
    }
    r.kind = ClientRequest::Kind::kUnadvertise;
    return r;
  }
  return Error("unsupported op '" + name + "' (" +
               (client_publish ? "this server supports subscribe, unsubscribe, advertise and "
                                 "unadvertise"
                               : "this server advertises no capabilities: only subscribe and "
                                 "unsubscribe") + ")");
}

ClientMessageData ParseClientBinary(std::string_view frame) {
  ClientMessageData m;
  if (frame.size() < 5) {
    m.error = "binary message of " + std::to_string(frame.size()) +
              " bytes: shorter than the 5-byte Client Message Data header";
    return m;
  }
  if (static_cast<uint8_t>(frame[0]) != 0x01) {
    m.error = "binary opcode " + std::to_string(static_cast<uint8_t>(frame[0])) +
              " is not supported (only 1, Client Message Data)";
    return m;
  }
  std::memcpy(&m.channel_id, frame.data() + 1, 4);
  m.payload = frame.substr(5);
  m.ok = true;
  return m;
}

}  // namespace hexa::bridge
