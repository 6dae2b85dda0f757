#include "bounded_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace hexa::config::internal {

bool ReadBoundedFile(const std::string& path, const char* what, std::size_t max_bytes,
                     std::string& text, std::string& error) {
  // O_NONBLOCK: opening a FIFO without a writer must not wait; the descriptor is checked to be
  // a regular file before anything is read from it (no stat-then-open race).
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK | O_NOCTTY);
  if (fd < 0) {
    error = std::string("cannot open ") + what + ": " + std::strerror(errno);
    return false;
  }
  struct stat st {};
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    error = std::string(what) + " is not a regular file (a device, FIFO or directory is never read)";
    ::close(fd);
    return false;
  }
  if (static_cast<unsigned long long>(st.st_size) > max_bytes) {
    error = std::string(what) + " is " + std::to_string(st.st_size) + " bytes, more than the limit of " +
            std::to_string(max_bytes) + " bytes";
    ::close(fd);
    return false;
  }
  text.clear();
  char buf[8192];
  for (;;) {
    const ssize_t n = ::read(fd, buf, sizeof buf);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) {
      error = std::string("cannot read ") + what + ": " + std::strerror(errno);
      ::close(fd);
      return false;
    }
    if (n == 0) break;
    text.append(buf, static_cast<std::size_t>(n));
    if (text.size() > max_bytes) {  // grew while being read
      error = std::string(what) + " is larger than the limit of " + std::to_string(max_bytes) + " bytes";
      ::close(fd);
      return false;
    }
  }
  ::close(fd);
  return true;
}

}  // namespace hexa::config::internal
