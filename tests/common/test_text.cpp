// Free text sanitising (hexa/services/text.hpp) and its uses at the edges of a process: the
// bounded char arrays of the DDS wire types (CopyBounded) and every log line (logging::Init).
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>

#include "hexa/services/format_cut.hpp"
#include "hexa/services/logging.hpp"
#include "hexa/services/node.hpp"
#include "hexa/services/text.hpp"

namespace hexa::text {
namespace {

std::string RandomBytes(std::size_t n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::string s(n, '\0');
  for (auto& c : s) c = static_cast<char>(rng() & 0xff);
  return s;
}

// Independent check of the output (not the same code as the sanitiser): decode every code
// point, reject overlong forms, surrogates, values above U+10FFFF and control characters.
bool ValidAndNoControls(const std::string& s, bool allow_newline) {
  for (std::size_t i = 0; i < s.size();) {
    const auto c = static_cast<unsigned char>(s[i]);
    std::uint32_t cp = 0;
    int extra = 0;
    if (c < 0x80) { cp = c; extra = 0; }
    else if ((c & 0xE0) == 0xC0) { cp = c & 0x1F; extra = 1; }
    else if ((c & 0xF0) == 0xE0) { cp = c & 0x0F; extra = 2; }
    else if ((c & 0xF8) == 0xF0) { cp = c & 0x07; extra = 3; }
    else return false;
    if (i + static_cast<std::size_t>(extra) >= s.size()) return false;
    for (int k = 1; k <= extra; ++k) {
      const auto d = static_cast<unsigned char>(s[i + static_cast<std::size_t>(k)]);
      if ((d & 0xC0) != 0x80) return false;
      cp = (cp << 6) | (d & 0x3F);
    }
    static const std::uint32_t kMin[4] = {0, 0x80, 0x800, 0x10000};
    if (cp < kMin[extra] || cp > 0x10FFFF || (cp >= 0xD800 && cp <= 0xDFFF)) return false;
    if ((cp < 0x20 && cp != '\t' && !(allow_newline && cp == '\n')) || cp == 0x7F) return false;
    i += static_cast<std::size_t>(extra) + 1;
  }
  return true;
}

TEST(Text, CleanTextIsUnchanged) {
  const std::string s = "leg 3 at t=2.450 s: caf\xC3\xA9 \xE2\x82\xAC \xF0\x9F\x98\x80\ttab";
  EXPECT_TRUE(IsClean(s, 1000));
  EXPECT_EQ(Sanitize(s, 1000), s);
  EXPECT_TRUE(IsValidUtf8(s));
}

TEST(Text, InvalidSequencesBecomeReplacementCharacters) {
  // Overlong '/', a lone continuation byte, a surrogate, above U+10FFFF, a truncated sequence.
  const std::string bad = "a\xC0\xAF" "b\x80" "c\xED\xA0\x80" "d\xF4\x90\x80\x80" "e\xE2\x82";
  EXPECT_FALSE(IsValidUtf8(bad));
  const std::string out = Sanitize(bad, 1000);
  EXPECT_TRUE(IsValidUtf8(out));
  EXPECT_TRUE(ValidAndNoControls(out, false)) << out;
  EXPECT_EQ(out.substr(0, 1), "a");
  EXPECT_NE(out.find("b"), std::string::npos);
  EXPECT_NE(out.find(kReplacement), std::string::npos);
  EXPECT_EQ(RepairUtf8("ok\xFFok"), "ok" + std::string(kReplacement) + "ok");
}

TEST(Text, ControlCharactersReplacedNewlinesOnlyWhereAllowed) {
  const std::string s = "line1\nline2\r\x1b[31mred\x7f\0x";
  EXPECT_EQ(Sanitize(s, 100).find('\n'), std::string::npos);
  EXPECT_EQ(Sanitize(s, 100).find('\x1b'), std::string::npos);
  EXPECT_NE(Sanitize(s, 100, Newlines::kKeep).find('\n'), std::string::npos);
  EXPECT_EQ(Sanitize(s, 100, Newlines::kKeep).find('\r'), std::string::npos);
}

TEST(Text, LongTextIsCutAtACharacterBoundaryWithAMarker) {
  std::string euros;
  for (int i = 0; i < 100; ++i) euros += "\xE2\x82\xAC";  // 3 bytes each
  for (std::size_t max = 0; max < 40; ++max) {
    const std::string out = Sanitize(euros, max);
    EXPECT_LE(out.size(), max);
    EXPECT_TRUE(IsValidUtf8(out)) << max;
    if (max >= kCutMarker.size()) {
      EXPECT_EQ(out.substr(out.size() - kCutMarker.size()), kCutMarker);
    }
  }
  EXPECT_EQ(Sanitize("12345678", 8), "12345678");  // exactly fits: no marker
  EXPECT_EQ(Sanitize("123456789", 8), "123[...]");
}

TEST(Text, RandomBytesAlwaysGiveValidBoundedText) {
  for (std::uint64_t seed = 1; seed <= 300; ++seed) {
    const std::string in = RandomBytes(1 + seed * 7 % 997, seed);
    for (std::size_t max : {std::size_t{0}, std::size_t{4}, std::size_t{17}, std::size_t{160}, std::size_t{5000}}) {
      const std::string out = Sanitize(in, max);
      ASSERT_LE(out.size(), max);
      ASSERT_TRUE(ValidAndNoControls(out, false)) << "seed " << seed << " max " << max;
      ASSERT_TRUE(IsClean(out, max));
      char buffer[161];
      const std::size_t n = SanitizeInto(in, buffer);
      ASSERT_EQ(n, std::strlen(buffer));
      ASSERT_LE(n, 160u);
      ASSERT_TRUE(ValidAndNoControls(buffer, false));
      ASSERT_EQ(std::string(buffer), Sanitize(in, 160));
    }
  }
}

// FormatCut: printf cut to the array on purpose (a DDS detail field), never mid-character.
TEST(Text, FormatCutCutsToTheArrayAtACharacterBoundary) {
  char fits[8];
  EXPECT_FALSE(FormatCut(fits, sizeof fits, "#%u %s", 12u, "abc"));  // 7 bytes + NUL
  EXPECT_STREQ(fits, "#12 abc");
  char cut[8];
  EXPECT_TRUE(FormatCut(cut, sizeof cut, "#%u %s", 12u, "abcd"));
  EXPECT_STREQ(cut, "#12 abc");
  char euro[8];  // "ab" + three euro signs (3 bytes each): the cut falls inside the second
  EXPECT_TRUE(FormatCut(euro, sizeof euro, "ab%s", "\xE2\x82\xAC\xE2\x82\xAC\xE2\x82\xAC"));
  EXPECT_STREQ(euro, "ab\xE2\x82\xAC");
  EXPECT_TRUE(IsValidUtf8(euro));
  char exact[6];  // "ab" + one euro sign: 5 bytes, fits
  EXPECT_FALSE(FormatCut(exact, sizeof exact, "ab%s", "\xE2\x82\xAC"));
  EXPECT_STREQ(exact, "ab\xE2\x82\xAC");
}

// The wire types' bounded strings (FaultEvent.detail, NodeStatus.detail: string<160>): the copy
// used to cut at byte 160 whatever was there, leaving invalid UTF-8 on the wire.
TEST(Text, CopyBoundedGivesValidUtf8ForTheWire) {
  char detail[161];
  std::string text(158, 'x');
  text += "\xE2\x82\xAC\xE2\x82\xAC";  // a 3-byte character straddles byte 160
  node::CopyBounded(detail, text.c_str());
  EXPECT_TRUE(IsValidUtf8(detail));
  EXPECT_LE(std::strlen(detail), 160u);
  const std::string random = RandomBytes(5000, 7);
  node::CopyBounded(detail, random.c_str());
  EXPECT_TRUE(ValidAndNoControls(detail, false));
}

// A 10 MB value must not become a 10 MB log line, and bytes that are not UTF-8 must not
// reach the log file.
TEST(Text, LogLinesAreBoundedAndValid) {
  const std::string path = std::filesystem::temp_directory_path() /
                           ("hexa_log_test_" + std::to_string(::getpid()) + ".log");
  const auto previous = spdlog::default_logger();  // Init replaces the process's default logger
  {
    auto log = logging::Init("logtest", path);
    log->error("value '{}' rejected", std::string(10 * 1024 * 1024, 'Z'));
    log->warn("bytes {}", RandomBytes(3000, 3));
    log->info("two\nlines stay two");
    log->flush();
    spdlog::set_default_logger(previous);  // later tests log through spdlog's free functions
  }
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string all = ss.str();
  std::filesystem::remove(path);
  EXPECT_LT(all.size(), 3 * kMaxLogLineBytes) << "the 10 MB value was echoed";
  EXPECT_TRUE(ValidAndNoControls(all, true));
  EXPECT_NE(all.find(std::string(kCutMarker)), std::string::npos);
  EXPECT_NE(all.find("two\nlines stay two"), std::string::npos);
}

}  // namespace
}  // namespace hexa::text
