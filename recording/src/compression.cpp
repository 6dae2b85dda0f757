#include "compression.hpp"

#include <zstd.h>

#include "hexa/recording/mcap.hpp"

namespace hexa::recorder {

ZstdCodec::ZstdCodec() = default;

ZstdCodec::~ZstdCodec() {
  ZSTD_freeCCtx(cctx_);
  ZSTD_freeDCtx(dctx_);
}

void ZstdCodec::Compress(std::string_view in, int level, std::string& out) {
  if (cctx_ == nullptr && (cctx_ = ZSTD_createCCtx()) == nullptr)
    throw McapError("zstd: cannot create a compression context (out of memory)");
  out.resize(ZSTD_compressBound(in.size()));
  const size_t n = ZSTD_compressCCtx(cctx_, out.data(), out.size(), in.data(), in.size(), level);
  if (ZSTD_isError(n)) throw McapError(std::string("zstd compression failed: ") + ZSTD_getErrorName(n));
  out.resize(n);
}

void ZstdCodec::Decompress(std::string_view in, uint64_t expected_size, std::string& out,
                           const std::string& what) {
  if (expected_size > kMaxChunkBytes)
    throw McapError(what + ": uncompressed_size " + std::to_string(expected_size) +
                    " exceeds the " + std::to_string(kMaxChunkBytes) +
                    " bytes this reader accepts for one chunk (corrupt size field?)");
  const unsigned long long frame_size = ZSTD_getFrameContentSize(in.data(), in.size());
  if (frame_size == ZSTD_CONTENTSIZE_ERROR)
    throw McapError(what + ": the chunk's records are not a zstd frame (corrupt chunk)");
  if (frame_size != ZSTD_CONTENTSIZE_UNKNOWN && frame_size != expected_size)
    throw McapError(what + ": zstd frame holds " + std::to_string(frame_size) +
                    " bytes but the chunk's uncompressed_size says " +
                    std::to_string(expected_size));
  if (dctx_ == nullptr && (dctx_ = ZSTD_createDCtx()) == nullptr)
    throw McapError("zstd: cannot create a decompression context (out of memory)");
  out.resize(expected_size);
  const size_t n = ZSTD_decompressDCtx(dctx_, out.data(), out.size(), in.data(), in.size());
  if (ZSTD_isError(n))
    throw McapError(what + ": zstd decompression failed: " + ZSTD_getErrorName(n) +
                    " (corrupt chunk)");
  if (n != expected_size)
    throw McapError(what + ": zstd frame expands to " + std::to_string(n) +
                    " bytes but the chunk's uncompressed_size says " +
                    std::to_string(expected_size));
}

}  // namespace hexa::recorder
