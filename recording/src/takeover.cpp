#include "hexa/recording/takeover.hpp"

#include <algorithm>

namespace hexa::recorder {

void TakeoverDetector::Add(std::uint32_t leg, std::uint64_t tick, bool standby) {
  if (standby) {
    standby_ticks_[leg].push_back(tick);
  } else {
    auto [it, inserted] = last_primary_tick_.try_emplace(leg, tick);
    if (!inserted) it->second = std::max(it->second, tick);
  }
}

std::vector<Takeover> TakeoverDetector::Find() const {
  std::vector<Takeover> out;
  for (const auto& [leg, unsorted] : standby_ticks_) {
    std::vector<std::uint64_t> ticks = unsorted;
    std::sort(ticks.begin(), ticks.end());
    const auto primary = last_primary_tick_.find(leg);
    const bool any_primary = primary != last_primary_tick_.end();
    const auto first =
        any_primary ? std::upper_bound(ticks.begin(), ticks.end(), primary->second) : ticks.begin();
    if (first == ticks.end()) continue;  // the primary answered to the end
    Takeover t;
    t.leg = leg;
    t.first_standby_tick = *first;
    if (any_primary) t.last_primary_tick = primary->second;
    t.standby_commands = static_cast<std::size_t>(ticks.end() - first);
    out.push_back(t);
  }
  return out;
}

}  // namespace hexa::recorder
