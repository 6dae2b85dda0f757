// DDS subcommands of hexa_recorder: record, play (through the comm layer).
#include "cli.hpp"

namespace hexa::recorder::cli {
int RunRecord(const std::vector<std::string>&) { throw std::runtime_error("record: not yet"); }
int RunPlay(const std::vector<std::string>&) { throw std::runtime_error("play: not yet"); }
}  // namespace hexa::recorder::cli
