#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "hexa/core/command_hygiene.hpp"

namespace hexa {
namespace {

CommandHygieneParams Params(std::uint64_t tolerance) {
  return CommandHygieneParams::FromValve(ValveParams{}, tolerance);
}

TEST(CommandHygiene, GoodCommandPassesThrough) {
  const LatestCommand c{true, 100, 7.5};
  EXPECT_EQ(CheckCommand(c, 100, Params(0)), CommandCheck::kOk);
  EXPECT_EQ(SafeValveVoltage(c, CommandCheck::kOk, Params(0)), 7.5);
  EXPECT_EQ(CheckCommand({true, 100, 0.0}, 100, Params(0)), CommandCheck::kOk);   // ends of
  EXPECT_EQ(CheckCommand({true, 100, 10.0}, 100, Params(0)), CommandCheck::kOk);  // the range
}

TEST(CommandHygiene, EveryBadCommandGivesNull) {
  const auto p = Params(3);
  struct Case {
    LatestCommand cmd;
    std::uint64_t tick;
    CommandCheck expected;
  };
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  const Case cases[] = {
      {{false, 0, 6.0}, 10, CommandCheck::kMissing},
      {{false, 0, 6.0}, 3, CommandCheck::kAwaitingFirst},  // start-up, within tolerance
      {{true, 6, 6.0}, 10, CommandCheck::kStale},       // 4 ticks old, tolerance 3
      {{true, 11, 6.0}, 10, CommandCheck::kStale},      // from the future
      {{true, 10, nan}, 10, CommandCheck::kNotFinite},
      {{true, 10, inf}, 10, CommandCheck::kNotFinite},
      {{true, 10, -0.01}, 10, CommandCheck::kOutOfRange},
      {{true, 10, 10.01}, 10, CommandCheck::kOutOfRange},
  };
  for (const auto& c : cases) {
    const CommandCheck check = CheckCommand(c.cmd, c.tick, p);
    EXPECT_EQ(check, c.expected) << ToString(c.expected);
    EXPECT_EQ(SafeValveVoltage(c.cmd, check, p), 5.0) << ToString(c.expected);
  }
  EXPECT_EQ(CheckCommand({true, 7, 6.0}, 10, p), CommandCheck::kOk);  // 3 ticks: tolerated
}

}  // namespace
}  // namespace hexa
