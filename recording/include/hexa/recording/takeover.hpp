// Hot-standby take-overs read from a recording's ValveCommands: the one rule that the report
// (report.md, report.json) and the plot marks (events.csv) both use.
//
// A standby that wrote after its primary's last command drove the valve from then on (the
// plant applies the live primary, else the live standby). The take-over is the standby's
// first command after the primary's last one: a standby's sample can reach the recorder
// earlier (at tick 0, or when the primary is late past its deadline and exclusive ownership
// lets the next sample in from any live writer), and that is no take-over.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <optional>
#include <vector>

namespace hexa::recorder {

struct Takeover {
  std::uint32_t leg = 0;
  std::uint64_t first_standby_tick = 0;            // the standby drives the valve from here
  std::optional<std::uint64_t> last_primary_tick;  // none: no command of the primary recorded
  std::size_t standby_commands = 0;                // the standby's commands from then on
};

class TakeoverDetector {
 public:
  // One recorded ValveCommand of `leg` (any order; a repeated tick counts once per sample).
  void Add(std::uint32_t leg, std::uint64_t tick, bool standby);
  // One entry per leg whose standby took over, by leg.
  std::vector<Takeover> Find() const;

 private:
  std::map<std::uint32_t, std::uint64_t> last_primary_tick_;
  std::map<std::uint32_t, std::vector<std::uint64_t>> standby_ticks_;
};

}  // namespace hexa::recorder
