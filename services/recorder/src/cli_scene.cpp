// hexa_recorder annotate: adds the 3-D scene (docs/foxglove.md) to a recording made without it,
// and the scene options that `record` shares.
#include <cinttypes>
#include <cstdio>
#include <functional>
#include <set>

#include "cli.hpp"
#include "hexa/config/rig_config.hpp"
#include "hexa/recording/scene.hpp"
#include "recording.pb.h"

namespace hexa::recorder::cli {

const char* kSceneOptionsHelp =
    "3-D scene (foxglove.SceneUpdate on hexa_Scene, foxglove.FrameTransforms on\n"
    "hexa_FrameTransforms, docs/foxglove.md):\n"
    "  --rig FILE          rig file whose joints are drawn (default: the reference rig)\n"
    "  --profile NAME      disturbance profile of the simulated plant (with --seed)\n"
    "  --seed N            seed of the simulated plant: the ground-truth platform is drawn on\n"
    "                      the plant's true joints (nominal + per-seed errors); without it, on\n"
    "                      the nominal joints (legs then differ from the true lengths by the\n"
    "                      calibration errors, up to ~4 mm with the realistic profile)\n"
    "  --scene-hz HZ       display rate in frames per simulated second (default 50)\n";

SceneOptions SceneOptionsFromArgs(const Args& a) {
  std::optional<std::uint64_t> seed;
  if (a.Has("seed")) {
    const long long s = a.GetInt("seed", 0);
    if (s < 0) throw UsageError("--seed must be >= 0");
    seed = static_cast<std::uint64_t>(s);
  }
  if (a.Has("profile") && !seed) throw UsageError("--profile needs --seed (the plant's seed)");
  SceneOptions o = SceneOptionsFromRig(a.Get("rig", config::DefaultRigFile()),
                                       a.Get("profile", ""), seed);
  const double hz = a.GetDouble("scene-hz", 50.0);
  if (!(hz >= 1.0 && hz <= 1000.0)) throw UsageError("--scene-hz must be in [1, 1000]");
  o.period_ticks = static_cast<std::uint64_t>(std::llround(1000.0 / hz));
  return o;
}

int RunAnnotate(const std::vector<std::string>& argv) {
  const Args a = ParseArgs(argv, {"output", "o", "compression", "rig", "profile", "seed",
                                  "scene-hz"}, {});
  if (a.help) {
    std::printf(
        "usage: hexa_recorder annotate IN.mcap --output OUT.mcap [--rig FILE] [--profile NAME\n"
        "                              --seed N] [--scene-hz HZ] [--compression none|zstd]\n"
        "Copies every channel and message of IN (sequence numbers and times kept) and adds the\n"
        "3-D scene computed from its ground truth, pose reports, valve commands and fault\n"
        "events, as `record` writes it live. A scene already in IN is replaced.\n%s",
        kSceneOptionsHelp);
    return kExitOk;
  }
  if (a.positional.size() != 1) throw UsageError("expected exactly one input recording");
  const std::string in = a.positional[0];
  const std::string out = a.Get("output", a.Get("o", ""));
  if (out.empty()) throw UsageError("--output FILE is required");
  if (out == in) throw UsageError("--output must differ from the input file");
  SceneBuilder builder(SceneOptionsFromArgs(a));
  McapWriterConfig config;
  config.compression = ParseCompressionOption(a);
  config.sync = McapSyncMode::kNone;  // one sync at Close() is enough for a rewrite
  RecordingWriter writer(config);
  writer.Open(out);

  McapReader reader;
  reader.Open(in);
  std::map<uint16_t, McapSchema> schemas;
  std::map<uint16_t, uint16_t> schema_map, channel_map;
  std::set<uint16_t> dropped;
  // Parsers of the channels the scene uses, by input channel id.
  std::map<uint16_t, std::function<const google::protobuf::Message*(std::string_view)>> parsers;
  rec::GroundTruth truth;
  rec::PoseReport pose;
  rec::ValveCommand valve;
  rec::FaultEvent fault;
  auto parser_for = [&](const std::string& type)
      -> std::function<const google::protobuf::Message*(std::string_view)> {
    google::protobuf::Message* m = nullptr;
    if (type == "hexa.rec.GroundTruth") m = &truth;
    if (type == "hexa.rec.PoseReport") m = &pose;
    if (type == "hexa.rec.ValveCommand") m = &valve;
    if (type == "hexa.rec.FaultEvent") m = &fault;
    if (m == nullptr) return nullptr;
    return [m](std::string_view data) -> const google::protobuf::Message* {
      return m->ParseFromArray(data.data(), static_cast<int>(data.size())) ? m : nullptr;
    };
  };
  std::unique_ptr<SceneChannels> scene;
  uint64_t copied = 0, unparsed = 0;
  McapVisitor v;
  v.on_schema = [&](const McapSchema& s) { schemas[s.id] = s; };
  v.on_channel = [&](const McapChannel& c) {
    if (channel_map.count(c.id) || dropped.count(c.id)) return;
    if (IsSceneChannel(c)) {
      dropped.insert(c.id);
      return;
    }
    uint16_t schema = 0;
    if (c.schema_id != 0) {
      auto it = schema_map.find(c.schema_id);
      if (it == schema_map.end()) {
        const McapSchema& s = schemas.at(c.schema_id);
        it = schema_map.emplace(c.schema_id, writer.mcap().AddSchema(s.name, s.encoding, s.data))
                 .first;
      }
      schema = it->second;
      if (c.message_encoding == kProtobufEncoding) {
        if (auto p = parser_for(schemas.at(c.schema_id).name)) parsers[c.id] = std::move(p);
      }
    }
    channel_map[c.id] = writer.mcap().AddChannel(schema, c.topic, c.message_encoding, c.metadata);
  };
  v.on_message = [&](const McapMessageView& m) {
    if (dropped.count(m.channel_id)) return;
    writer.mcap().WriteWithSequence(channel_map.at(m.channel_id), m.sequence, m.log_time_ns,
                                    m.publish_time_ns, m.data);
    ++copied;
    auto p = parsers.find(m.channel_id);
    if (p == parsers.end()) return;
    const google::protobuf::Message* msg = p->second(m.data);
    if (msg == nullptr) {
      ++unparsed;
      return;
    }
    if (builder.Add(*msg)) {
      if (!scene) scene = std::make_unique<SceneChannels>(writer, builder.options());
      builder.Build(m.log_time_ns);
      scene->Write(m.log_time_ns, builder);
    }
  };
  reader.Scan(v);
  writer.Close();
  std::printf("annotate: copied %" PRIu64 " messages (%zu channels%s), added %" PRIu64
              " scene frames (%s) -> %s\n",
              copied, channel_map.size(),
              dropped.empty() ? "" : ", the old scene channels dropped", builder.frames(),
              builder.options().geometry_note.c_str(), out.c_str());
  if (unparsed > 0)
    std::printf("annotate: %" PRIu64 " messages of the scene's inputs did not parse and were "
                "copied without use\n", unparsed);
  if (builder.frames() == 0)
    std::printf("annotate: no scene frame: the recording has no hexa.rec.GroundTruth or "
                "hexa.rec.PoseReport messages\n");
  return kExitOk;
}

}  // namespace hexa::recorder::cli
