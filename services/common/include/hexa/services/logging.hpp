// spdlog set-up shared by every process: one named logger, to the terminal and optionally
// to a file, with a pattern that names the process. Every message is made valid UTF-8 and
// bounded to text::kMaxLogLineBytes before it is written (hexa/services/text.hpp).
#pragma once

#include <memory>
#include <string>

#include <spdlog/spdlog.h>

namespace hexa::logging {

// Creates the default logger named `process_name`; `log_file` empty = terminal only.
std::shared_ptr<spdlog::logger> Init(const std::string& process_name,
                                     const std::string& log_file = {},
                                     const std::string& level = "info");

}  // namespace hexa::logging
