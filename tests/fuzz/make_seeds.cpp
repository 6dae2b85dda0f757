// Writes the binary seeds of the committed fuzz corpus (tests/fuzz/corpus/): small MCAP
// recordings for fuzz_mcap_reader and one serialised message per wire type for
// fuzz_recording_convert. Text seeds (rig files, CSV) are copies of the repository's files.
//   fuzz_make_seeds CORPUS_DIR
#include <cstdio>
#include <fstream>
#include <string>

#include "hexa/recording/convert.hpp"
#include "hexa/recording/recording.hpp"
#include "recording.pb.h"

namespace rec = hexa::rec;

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: fuzz_make_seeds CORPUS_DIR\n");
    return 2;
  }
  const std::string dir = argv[1];
  auto write_mcap = [&](const std::string& name, bool bad_utf8) {
    hexa::recorder::McapWriterConfig cfg;
    cfg.sync = hexa::recorder::McapSyncMode::kNone;
    cfg.chunk_max_messages = 8;
    hexa::recorder::RecordingWriter w(cfg);
    const std::string path = dir + "/fuzz_mcap_reader/" + name;
    w.Open(path);
    const uint16_t sens = w.AddTopic("hexa_LegSensors", *rec::LegSensors::descriptor(), {{"hexa.period_s", "0.001"}});
    const uint16_t fault = w.AddTopic("hexa_FaultEvent", *rec::FaultEvent::descriptor(), {{"hexa.period_s", "0"}});
    for (uint64_t tick = 1; tick <= 12; ++tick) {
      rec::LegSensors s;
      s.set_leg_id(1 + tick % 6);
      s.mutable_header()->set_tick(tick);
      s.set_length_m(0.5 + 1e-3 * tick);
      w.Write(sens, 1000 + tick, 900 + tick, s);
    }
    rec::FaultEvent f;
    f.set_source_node("supervisor");
    f.set_leg_id(3);
    f.set_tick(12);
    f.set_reason(rec::FAULT_TRAJECTORY_REJECTED);
    f.set_detail(bad_utf8 ? std::string("bad header \"\xff\xfe\"") : "trajectory rejected");
    w.Write(fault, 2000, 2000, f);
    w.Close();
    return path;
  };
  write_mcap("small.mcap", false);
  write_mcap("bad_utf8.mcap", true);
  {  // a truncated copy (the recorder killed): everything but the last 100 bytes
    std::ifstream in(dir + "/fuzz_mcap_reader/small.mcap", std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), {});
    std::ofstream(dir + "/fuzz_mcap_reader/truncated.mcap", std::ios::binary)
        << bytes.substr(0, bytes.size() - 100);
  }
  const auto& types = hexa::recorder::WireTypes();
  for (size_t i = 0; i < types.size(); ++i) {
    std::unique_ptr<google::protobuf::Message> m(types[i].prototype->New());
    // A default message of the type, plus a populated one where it has strings.
    std::string bytes = m->SerializeAsString();
    if (types[i].name == "FaultEvent") {
      rec::FaultEvent f;
      f.set_source_node("plant");
      f.set_detail("leg 3 command stale");
      f.set_leg_id(3);
      bytes = f.SerializeAsString();
    } else if (types[i].name == "LegSensors") {
      rec::LegSensors s;
      s.set_leg_id(2);
      s.mutable_header()->set_tick(7);
      s.set_length_m(0.51);
      bytes = s.SerializeAsString();
    } else if (types[i].name == "ImuSample") {
      rec::ImuSample s;
      for (double q : {1.0, 0.0, 0.0, 0.0}) s.add_orientation_wxyz(q);
      for (int k = 0; k < 3; ++k) s.add_angular_rate_rad_s(0.0);
      bytes = s.SerializeAsString();
    }
    std::ofstream(dir + "/fuzz_recording_convert/" + std::string(types[i].name), std::ios::binary)
        << static_cast<char>(i) << bytes;
  }
  return 0;
}
