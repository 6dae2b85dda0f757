// The shared command-line parser: a single-dash option or a stray word is an error naming
// it, never silently ignored ("hexa_session -trajectory x" used to run the default session).
#include <gtest/gtest.h>

#include <vector>

#include "hexa/services/cli.hpp"

namespace hexa::cli {
namespace {

bool ParseArgs(Parser& p, std::vector<const char*> args) {
  args.insert(args.begin(), "prog");
  return p.Parse(static_cast<int>(args.size()), args.data());
}

Parser MakeParser() {
  Parser p("prog", "test");
  p.AddOption("trajectory", "name", "trajectory", "combined");
  p.AddFlag("standby", "standby");
  return p;
}

TEST(Cli, SingleDashOptionIsRejectedWithAHint) {
  Parser p = MakeParser();
  EXPECT_FALSE(ParseArgs(p, {"-trajectory", "x"}));
  EXPECT_NE(p.error().find("unknown option '-trajectory'"), std::string::npos) << p.error();
  EXPECT_NE(p.error().find("--trajectory"), std::string::npos) << p.error();
  EXPECT_FALSE(p.help_requested());
}

TEST(Cli, UnknownSingleDashOptionIsRejected) {
  Parser p = MakeParser();
  EXPECT_FALSE(ParseArgs(p, {"-q"}));
  EXPECT_NE(p.error().find("'-q'"), std::string::npos) << p.error();
}

TEST(Cli, StrayWordIsRejectedUnlessPositionalsAreDeclared) {
  Parser p = MakeParser();
  EXPECT_FALSE(ParseArgs(p, {"x"}));
  EXPECT_NE(p.error().find("unexpected argument 'x'"), std::string::npos) << p.error();

  Parser q = MakeParser();
  q.AllowPositional("start|stop", 1);
  EXPECT_TRUE(ParseArgs(q, {"start", "--standby"}));
  ASSERT_EQ(q.positional().size(), 1u);
  EXPECT_EQ(q.positional()[0], "start");
  Parser r = MakeParser();
  r.AllowPositional("start|stop", 1);
  EXPECT_FALSE(ParseArgs(r, {"start", "stop"}));
  EXPECT_NE(r.error().find("expected start|stop"), std::string::npos) << r.error();
}

TEST(Cli, DoubleDashOptionsAndNegativeValuesStillWork) {
  Parser p("prog", "test");
  p.AddOption("offset", "m", "offset", "0");
  EXPECT_TRUE(ParseArgs(p, {"--offset", "-0.5"}));
  EXPECT_EQ(p.Get("offset"), "-0.5");
  Parser h = MakeParser();
  EXPECT_FALSE(ParseArgs(h, {"-h"}));
  EXPECT_TRUE(h.help_requested());
}

TEST(Cli, NonFiniteNumbersAreRejected) {
  Parser p("prog", "test");
  p.AddOption("at", "s", "time", "0");
  ASSERT_TRUE(ParseArgs(p, {"--at", "inf"}));
  EXPECT_FALSE(p.GetDouble("at", 0, 1e300).has_value());
  Parser q("prog", "test");
  q.AddOption("at", "s", "time", "0");
  ASSERT_TRUE(ParseArgs(q, {"--at=nan"}));
  EXPECT_FALSE(q.GetDouble("at", -1e300, 1e300).has_value());
}

TEST(Cli, IntegerOrWordReadsTheWordAsItsValueAndChecksNumbers) {
  auto read = [](const char* value) {
    Parser p("prog", "test");
    p.AddOption("cpu-latency-us", "N|none", "latency", "0");
    EXPECT_TRUE(ParseArgs(p, {"--cpu-latency-us", value}));
    return p.GetIntOrWord("cpu-latency-us", "none", -1, 0, 100);
  };
  EXPECT_EQ(read("none"), -1);
  EXPECT_EQ(read("7"), 7);
  EXPECT_FALSE(read("101").has_value());   // outside [0, 100]
  EXPECT_FALSE(read("-1").has_value());    // the word's value is not a valid number
  EXPECT_FALSE(read("None").has_value());  // the word exactly
}

}  // namespace
}  // namespace hexa::cli
