#include "hexa/comm/writer.hpp"

#include <algorithm>
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

int CountMatchedReadersWithUserData(dds_entity_t writer, const std::string& user_data) {
  dds_instance_handle_t handles[64];
  const dds_return_t n = dds_get_matched_subscriptions(writer, handles, 64);
  int count = 0;
  for (dds_return_t i = 0; i < std::min<dds_return_t>(n, 64); ++i) {
    dds_builtintopic_endpoint_t* ep = dds_get_matched_subscription_data(writer, handles[i]);
    if (ep == nullptr) continue;  // no longer matched
    void* value = nullptr;
    size_t size = 0;
    if (ep->qos != nullptr && dds_qget_userdata(ep->qos, &value, &size) && value != nullptr) {
      if (std::string(static_cast<const char*>(value), size) == user_data) ++count;
      dds_free(value);
    }
    dds_builtintopic_free_endpoint(ep);
  }
  return count;
}

}  // namespace hexa::comm
