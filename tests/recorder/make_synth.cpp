// Writes the deterministic synthetic recording of synth.hpp (used by the JS reader test).
#include <cstdio>

#include "synth.hpp"

int main(int argc, char** argv) {
  if (argc != 2 && argc != 3) {
    std::fprintf(stderr, "usage: rec_make_synth OUT.mcap [none|zstd]   (default zstd)\n");
    return 2;
  }
  hexa::recorder::McapWriterConfig config;
  config.chunk_max_bytes = 64 * 1024;  // several chunks
  if (argc == 3) config.compression = hexa::recorder::ParseMcapCompression(argv[2]);
  hexa::recorder::test::WriteSynthRecording(argv[1], config);
  return 0;
}
