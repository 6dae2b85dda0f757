// Counts heap allocations made by the calling thread: interposes malloc / calloc / realloc
// (forwarding to glibc's __libc_* functions), so other threads (Cyclone's receive threads,
// which allocate for incoming data) do not count. Include it in exactly one translation unit
// of a test binary: it defines the C allocation functions of that binary.
#pragma once

#include <cstddef>
#include <cstdint>

extern "C" {
void* __libc_malloc(std::size_t);
void* __libc_calloc(std::size_t, std::size_t);
void* __libc_realloc(void*, std::size_t);
}

namespace hexa::testing {
inline thread_local bool t_counting = false;
inline thread_local std::uint64_t t_allocations = 0;
}  // namespace hexa::testing

extern "C" {
void* malloc(std::size_t n) {
  if (hexa::testing::t_counting) ++hexa::testing::t_allocations;
  return __libc_malloc(n);
}
void* calloc(std::size_t n, std::size_t m) {
  if (hexa::testing::t_counting) ++hexa::testing::t_allocations;
  return __libc_calloc(n, m);
}
void* realloc(void* p, std::size_t n) {
  if (hexa::testing::t_counting) ++hexa::testing::t_allocations;
  return __libc_realloc(p, n);
}
}
