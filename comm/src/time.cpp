#include "hexa/comm/time.hpp"

#include <time.h>

namespace hexa::comm {

int64_t RealtimeNow_ns() {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<int64_t>(ts.tv_sec) * 1000000000LL + ts.tv_nsec;
}

}  // namespace hexa::comm
