// Splitting a long recording into files by size or time, with a retention limit: a real-time
// session records about 4.6 GB an hour. The open file keeps the recording's name
// (session.mcap); each closed part is renamed session-0001.mcap, session-0002.mcap, ... in
// order, and the oldest parts beyond the limit are deleted. Every part is a complete MCAP file
// with every schema and channel (McapWriter::Rotate).
#pragma once

#include <cstdint>
#include <deque>
#include <string>
#include <vector>

#include "hexa/recording/mcap.hpp"

namespace hexa::recorder {

struct RotationConfig {
  std::uint64_t split_bytes = 0;  // 0: no split by size
  std::uint64_t split_ns = 0;     // 0: no split by time (log time)
  std::uint32_t keep_files = 0;   // files kept in all, the open one included; 0: every file
  bool enabled() const { return split_bytes > 0 || split_ns > 0; }
  // Throws std::invalid_argument naming the option and the value.
  void Validate() const;
};

class RecordingRotation {
 public:
  // `path`: the recording's name (the open file); `opened_ns`: when it was opened.
  RecordingRotation(RotationConfig config, std::string path, std::uint64_t opened_ns);
  // True when the open file has reached the size or age limit.
  bool Due(const McapWriter& writer, std::uint64_t now_ns) const;
  // Closes the open part under the next part name, opens a new file under the recording's
  // name, deletes the oldest parts beyond keep_files. Throws McapError on a file error.
  void Rotate(McapWriter& writer, std::uint64_t now_ns);
  // Closed parts still on disk, oldest first; and how many were deleted.
  const std::deque<std::string>& parts() const { return parts_; }
  const std::vector<std::string>& deleted() const { return deleted_; }
  // The name of closed part `index` (1-based): session.mcap -> session-0001.mcap.
  static std::string PartPath(const std::string& path, unsigned index);

 private:
  RotationConfig config_;
  std::string path_;
  std::uint64_t opened_ns_;
  unsigned next_index_ = 1;
  std::deque<std::string> parts_;
  std::vector<std::string> deleted_;
};

}  // namespace hexa::recorder
