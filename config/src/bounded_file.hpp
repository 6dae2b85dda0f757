// Reading a user's file whole, with a size limit: rig files and overlays are a few kilobytes,
// and a path such as /dev/zero or a FIFO must give an error, not a read that never ends.
#pragma once

#include <cstddef>
#include <string>

namespace hexa::config::internal {

// Rig files and rig overlays: the reference rig file is about 10 kB.
constexpr std::size_t kMaxRigFileBytes = 1 << 20;

// Reads a regular file of at most `max_bytes` into `text`. False with `error` (naming `what`,
// e.g. "rig file", not the path) when it cannot be opened or read, is not a regular file, or is
// larger than the limit.
bool ReadBoundedFile(const std::string& path, const char* what, std::size_t max_bytes,
                     std::string& text, std::string& error);

}  // namespace hexa::config::internal
