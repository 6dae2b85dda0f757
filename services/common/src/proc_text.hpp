// Reading a small /proc file (a line of numbers) without allocating: for the scheduler
// statistics a leg controller reads on every check of its cycle, and for the state of a peer's
// process (not installed).
#pragma once

#include <fcntl.h>
#include <unistd.h>

#include <cstddef>

namespace hexa::proc {

// `path`'s first `size` - 1 bytes into `text`, NUL-terminated; false when the file cannot be
// opened (the thread or process is gone) or is empty.
inline bool ReadText(const char* path, char* text, std::size_t size) {
  const int fd = open(path, O_RDONLY | O_CLOEXEC);
  if (fd < 0) return false;
  const ssize_t n = read(fd, text, size - 1);
  close(fd);
  if (n <= 0) return false;
  text[n] = '\0';
  return true;
}

}  // namespace hexa::proc
