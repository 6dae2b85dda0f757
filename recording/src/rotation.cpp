#include "hexa/recording/rotation.hpp"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <stdexcept>

namespace hexa::recorder {

void RotationConfig::Validate() const {
  if (keep_files > 0 && !enabled())
    throw std::invalid_argument("keep_files = " + std::to_string(keep_files) +
                                " without a split by size or time: nothing to rotate");
}

RecordingRotation::RecordingRotation(RotationConfig config, std::string path,
                                     std::uint64_t opened_ns)
    : config_(config), path_(std::move(path)), opened_ns_(opened_ns) {
  config_.Validate();
}

std::string RecordingRotation::PartPath(const std::string& path, unsigned index) {
  const auto slash = path.rfind('/');
  const auto dot = path.rfind('.');
  const bool has_ext = dot != std::string::npos && (slash == std::string::npos || dot > slash + 1);
  char number[16];
  std::snprintf(number, sizeof number, "-%04u", index);
  return has_ext ? path.substr(0, dot) + number + path.substr(dot) : path + number;
}

bool RecordingRotation::Due(const McapWriter& writer, std::uint64_t now_ns) const {
  if (config_.split_bytes > 0 && writer.file_bytes() >= config_.split_bytes) return true;
  return config_.split_ns > 0 && now_ns >= opened_ns_ && now_ns - opened_ns_ >= config_.split_ns;
}

void RecordingRotation::Rotate(McapWriter& writer, std::uint64_t now_ns) {
  const std::string part = PartPath(path_, next_index_);
  // Renamed while open: the writer finishes the same file under its new name.
  if (std::rename(path_.c_str(), part.c_str()) != 0)
    throw McapError("cannot rename '" + path_ + "' to '" + part + "': " + std::strerror(errno));
  ++next_index_;
  writer.Rotate(path_);
  opened_ns_ = now_ns;
  parts_.push_back(part);
  while (config_.keep_files > 0 && parts_.size() + 1 > config_.keep_files) {
    if (std::remove(parts_.front().c_str()) != 0 && errno != ENOENT)
      throw McapError("cannot delete '" + parts_.front() + "': " + std::strerror(errno));
    deleted_.push_back(parts_.front());
    parts_.pop_front();
  }
}

}  // namespace hexa::recorder
