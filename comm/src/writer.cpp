#include "hexa/comm/writer.hpp"

#include <atomic>

namespace hexa::comm {
namespace {
std::atomic<bool> g_write_batching{false};
}  // namespace

void EnableWriteBatching() {
  dds_write_set_batch(true);
  g_write_batching.store(true, std::memory_order_release);
}

bool WriteBatchingEnabled() { return g_write_batching.load(std::memory_order_acquire); }

}  // namespace hexa::comm
