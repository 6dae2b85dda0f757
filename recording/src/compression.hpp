// zstd chunk compression of the MCAP layer (libzstd, Debian libzstd-dev). Internal to mcap.cpp:
// one compression and one decompression context, reused chunk after chunk (no allocation per
// chunk once the buffers have grown).
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

struct ZSTD_CCtx_s;
struct ZSTD_DCtx_s;

namespace hexa::recorder {

class ZstdCodec {
 public:
  ZstdCodec();
  ~ZstdCodec();
  ZstdCodec(const ZstdCodec&) = delete;
  ZstdCodec& operator=(const ZstdCodec&) = delete;

  // Replaces `out` by one zstd frame holding `in` (content size recorded in the frame).
  // Throws McapError on a libzstd failure.
  void Compress(std::string_view in, int level, std::string& out);
  // Decompresses one zstd frame that must expand to exactly `expected_size` bytes into `out`.
  // Throws McapError (with `what` in front) when the data is not a valid frame, expands to
  // another size, or `expected_size` exceeds kMaxChunkBytes.
  void Decompress(std::string_view in, uint64_t expected_size, std::string& out,
                  const std::string& what);

  // Largest uncompressed chunk the reader accepts: guards against a corrupt size field asking
  // for an absurd allocation. The writer closes chunks at <= 4 GiB (chunk_max_bytes), by
  // default at 1 MiB.
  static constexpr uint64_t kMaxChunkBytes = 1ull << 32;

 private:
  ZSTD_CCtx_s* cctx_ = nullptr;
  ZSTD_DCtx_s* dctx_ = nullptr;
};

}  // namespace hexa::recorder
