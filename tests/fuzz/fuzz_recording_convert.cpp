// libFuzzer target: the recorder's protobuf conversion (services/recorder convert.hpp) in
// both directions. (1) Arbitrary bytes as a DDS sample of each wire type (any bytes in its
// bounded strings) -> ToProto -> serialise -> parse must succeed: a recorded message is always
// readable again (bytes that were not UTF-8 made recordings unreadable). (2) Arbitrary
// bytes parsed as each recorded message (with the UTF-8 repair of recording.hpp) -> FromProto
// -> ToProto: never crashes; a message FromProto accepts survives the round trip.
#include <google/protobuf/stubs/logging.h>

#include <cstddef>
#include <cstdint>
#include <algorithm>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "hexa/recording/convert.hpp"
#include "hexa/recording/recording.hpp"

// libprotobuf logs every string that is not UTF-8 while parsing (the reader repairs them):
// silenced, it would drown libFuzzer's output.
extern "C" int LLVMFuzzerInitialize(int*, char***) {
  google::protobuf::SetLogHandler(nullptr);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return -1;
  const auto& types = hexa::recorder::WireTypes();
  const hexa::recorder::WireType& t = types[data[0] % types.size()];
  const uint8_t* body = data + 1;
  const size_t body_size = size - 1;

  // (1) DDS sample -> protobuf, with any bytes in the bounded strings (hexa.idl: FaultEvent,
  // NodeStatus, OperatorCommand carry text). Other fields keep valid values: a DDS reader never
  // delivers a bool that is neither 0 nor 1.
  {
    std::vector<unsigned char> sample(t.sample_size, 0);
    auto fill = [&](char* dst, size_t n, size_t from) {
      for (size_t i = 0; i < n; ++i) dst[i] = from + i < body_size ? static_cast<char>(body[from + i]) : 0;
    };
    if (t.name == "FaultEvent") {
      auto* f = reinterpret_cast<hexa_msg_FaultEvent*>(sample.data());
      fill(f->source_node, sizeof f->source_node, 0);
      fill(f->detail, sizeof f->detail, sizeof f->source_node);
    } else if (t.name == "NodeStatus") {
      auto* n = reinterpret_cast<hexa_msg_NodeStatus*>(sample.data());
      fill(n->node_name, sizeof n->node_name, 0);
      fill(n->detail, sizeof n->detail, sizeof n->node_name);
    } else if (t.name == "OperatorCommand") {
      auto* c = reinterpret_cast<hexa_msg_OperatorCommand*>(sample.data());
      fill(c->trajectory, sizeof c->trajectory, 0);
      fill(c->csv_path, sizeof c->csv_path, sizeof c->trajectory);
    }
    std::unique_ptr<google::protobuf::Message> proto(t.prototype->New());
    t.to_proto(sample.data(), *proto);
    std::string bytes;
    if (!proto->SerializeToString(&bytes)) __builtin_trap();
    std::unique_ptr<google::protobuf::Message> back(t.prototype->New());
    if (!back->ParseFromString(bytes)) __builtin_trap();  // readable again
  }

  // (2) protobuf bytes -> DDS sample -> protobuf.
  std::unique_ptr<google::protobuf::Message> parsed(t.prototype->New());
  const std::string_view wire(reinterpret_cast<const char*>(body), body_size);
  if (hexa::recorder::ParseRepairingUtf8(wire, *parsed) == hexa::recorder::ParseOutcome::kFailed) return 0;
  std::vector<unsigned char> out(t.sample_size, 0);
  if (!t.from_proto(*parsed, out.data())) return 0;
  std::unique_ptr<google::protobuf::Message> again(t.prototype->New());
  t.to_proto(out.data(), *again);
  std::string again_bytes;
  if (!again->SerializeToString(&again_bytes)) __builtin_trap();
  std::unique_ptr<google::protobuf::Message> reparsed(t.prototype->New());
  if (!reparsed->ParseFromString(again_bytes)) __builtin_trap();
  return 0;
}
