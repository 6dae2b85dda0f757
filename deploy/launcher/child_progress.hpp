// The session's progress as its children write it: the newest line of a child's console log
// that carries a progress marker ("record: progress: ", "report: ", "plot_session: "), shown
// by hexa_session on its own progress line (hexa::progress::Line).
#pragma once

#include <fstream>
#include <string>
#include <vector>

namespace hexa::deploy {

// Text after the marker on the newest line of `path` that contains one of `markers` (read from
// the last 8 KiB only); "" when there is none yet.
inline std::string NewestProgress(const std::string& path, const std::vector<std::string>& markers) {
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) return "";
  const std::streamoff size = in.tellg();
  const std::streamoff from = size > 8192 ? size - 8192 : 0;
  in.seekg(from);
  std::string tail(static_cast<std::size_t>(size - from), '\0');
  in.read(tail.data(), static_cast<std::streamsize>(tail.size()));
  std::string best;
  std::size_t best_at = 0;
  for (const auto& m : markers) {
    const std::size_t at = tail.rfind(m);
    if (at == std::string::npos || (!best.empty() && at < best_at)) continue;
    std::size_t end = tail.find_first_of("\r\n", at);
    best = tail.substr(at, end == std::string::npos ? std::string::npos : end - at);
    best_at = at;
  }
  return best;
}

}  // namespace hexa::deploy
