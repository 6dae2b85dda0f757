#include "hexa/services/json.hpp"

#include <cerrno>
#include <cstring>
#include <fstream>

namespace hexa::json {

std::string Dump(const Value& value, int indent) {
  return value.dump(indent, ' ', false, Value::error_handler_t::replace);
}

bool WriteFile(const std::string& path, const Value& value, int indent, std::string& error) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (out) out << Dump(value, indent) << '\n';
  out.flush();
  if (!out) {
    error = "cannot write " + path + ": " + std::strerror(errno);
    return false;
  }
  return true;
}

}  // namespace hexa::json
