// hexa_recorder attach: adds the session description and the plant's truth (text-format
// files written by the session launcher and the plant) to a finished recording as the
// channels hexa_SessionInfo and hexa_PlantTruth (docs/identification.md).
#include <google/protobuf/text_format.h>

#include <cstdio>
#include <fstream>
#include <memory>
#include <sstream>

#include "cli.hpp"
#include "hexa/recording/plant_truth.hpp"

namespace hexa::recorder::cli {
namespace {

template <typename T>
std::unique_ptr<T> ReadText(const std::string& path, const char* what) {
  std::ifstream in(path);
  if (!in) throw UsageError(std::string("cannot open ") + what + " file '" + path + "'");
  std::stringstream text;
  text << in.rdbuf();
  auto msg = std::make_unique<T>();
  if (!google::protobuf::TextFormat::ParseFromString(text.str(), msg.get())) {
    throw UsageError(std::string(what) + " file '" + path + "' is not a valid " + T::descriptor()->full_name() +
                     " in protobuf text format");
  }
  return msg;
}

}  // namespace

int RunAttach(const std::vector<std::string>& argv) {
  const Args a = ParseArgs(argv, {"session-info", "plant-truth"}, {});
  if (a.help) {
    std::printf(
        "usage: hexa_recorder attach RECORDING.mcap [--session-info FILE] [--plant-truth FILE]\n"
        "Adds hexa.rec.SessionInfo / hexa.rec.PlantTruth messages (protobuf text files) to a\n"
        "finished recording as channels hexa_SessionInfo / hexa_PlantTruth (the file is rewritten).\n");
    return kExitOk;
  }
  if (a.positional.size() != 1) throw UsageError("expected one recording");
  std::unique_ptr<rec::SessionInfo> info;
  std::unique_ptr<rec::PlantTruth> truth;
  std::vector<std::pair<std::string, const google::protobuf::Message*>> messages;
  if (a.Has("session-info")) {
    info = ReadText<rec::SessionInfo>(a.Get("session-info", ""), "session info");
    messages.emplace_back(kSessionInfoTopic, info.get());
  }
  if (a.Has("plant-truth")) {
    truth = ReadText<rec::PlantTruth>(a.Get("plant-truth", ""), "plant truth");
    messages.emplace_back(kPlantTruthTopic, truth.get());
  }
  if (messages.empty()) throw UsageError("nothing to attach (--session-info and/or --plant-truth)");
  const auto copied = AttachMessages(a.positional[0], messages);
  std::printf("attached %zu channel(s) to %s (%llu messages copied)\n", messages.size(),
              a.positional[0].c_str(), static_cast<unsigned long long>(copied));
  return kExitOk;
}

}  // namespace hexa::recorder::cli
