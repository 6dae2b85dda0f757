// libFuzzer target: the MCAP reader (services/recorder mcap.hpp) and the protobuf decoding of
// a recording with the schemas it embeds (recording.hpp ReadRecording), on arbitrary bytes, in
// strict and tolerant mode. Invariants: never crash; a bad file is an McapError (the CLI turns
// it into exit 2) - any other exception escapes and is reported by libFuzzer as a crash.
#include <sys/mman.h>
#include <unistd.h>

#include <google/protobuf/stubs/logging.h>

#include <cstddef>
#include <cstdint>
#include <string>

#include "hexa/recording/mcap.hpp"
#include "hexa/recording/recording.hpp"

namespace {
// One in-memory file reused for every input: the reader takes a path.
int MemFile() {
  static const int fd = memfd_create("fuzz_mcap", MFD_CLOEXEC);
  return fd;
}
}  // namespace

// libprotobuf logs every string that is not UTF-8 while parsing (the reader repairs them):
// silenced, it would drown libFuzzer's output.
extern "C" int LLVMFuzzerInitialize(int*, char***) {
  google::protobuf::SetLogHandler(nullptr);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size > 1 << 20) return -1;
  const int fd = MemFile();
  if (fd < 0 || ftruncate(fd, 0) != 0 || pwrite(fd, data, size, 0) != static_cast<ssize_t>(size))
    __builtin_trap();
  const std::string path = "/proc/self/fd/" + std::to_string(fd);
  for (const bool tolerant : {false, true}) {
    try {
      hexa::recorder::McapReader reader;
      reader.Open(path);
      hexa::recorder::McapVisitor v;
      uint64_t bytes = 0;
      v.on_message = [&](const hexa::recorder::McapMessageView& m) { bytes += m.data.size(); };
      hexa::recorder::McapScanOptions o;
      o.tolerant = tolerant;
      const auto r = reader.Scan(v, o);
      if (r.valid_data_end > r.file_size) __builtin_trap();
    } catch (const hexa::recorder::McapError&) {
    }
    try {
      hexa::recorder::McapScanOptions o;
      o.tolerant = tolerant;
      (void)hexa::recorder::ReadRecording(
          path,
          [](const hexa::recorder::McapChannel&, const hexa::recorder::McapMessageView&,
             const google::protobuf::Message& m) { (void)hexa::recorder::MessageTick(m); },
          o);
    } catch (const hexa::recorder::McapError&) {
    }
  }
  return 0;
}
