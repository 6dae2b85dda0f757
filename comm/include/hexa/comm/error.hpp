// Error reporting of the comm layer. Setup (participant, topic, reader, writer creation,
// configuration) throws DdsError with a message naming the entity, the domain and Cyclone's
// return code; the 1 ms cycle (write, take, read, wait) never throws and returns the
// dds_return_t instead (docs/style.md rule 5).
#pragma once

#include <dds/dds.h>

#include <stdexcept>
#include <string>

namespace hexa::comm {

class DdsError : public std::runtime_error {
 public:
  DdsError(const std::string& what, dds_return_t code)
      : std::runtime_error(what + ": " + dds_strretcode(code) + " (" + std::to_string(code) + ")"),
        code_(code) {}
  dds_return_t code() const { return code_; }

 private:
  dds_return_t code_;
};

// Throws DdsError when `result` (an entity handle or a return code) is negative.
inline dds_entity_t CheckDds(dds_entity_t result, const std::string& what) {
  if (result < 0) throw DdsError(what, result);
  return result;
}

}  // namespace hexa::comm
