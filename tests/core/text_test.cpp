#include "mimic/core/text.h"

#include <gtest/gtest.h>

#include <random>
#include <string>

namespace mimic::text_test {
namespace {

// No byte the output holds can start a terminal control: nothing below 0x20, no DEL, and the
// only bytes >= 0x80 are parts of valid UTF-8 sequences that are not C1 controls.
bool inert(const std::string& s) {
  if (!is_safe_name(s)) return false;
  for (const char ch : s)
    if (static_cast<uint8_t>(ch) < 0x20 || ch == 0x7F) return false;
  return true;
}

TEST(TerminalSafe, PrintableTextPassesUnchanged) {
  for (const char* s : {"avatar1", "Zoë ✓", "日本語", "emoji 😀", "a b-c_d.e"}) {
    EXPECT_EQ(terminal_safe(s), s);
    EXPECT_TRUE(is_safe_name(s)) << s;
  }
}

TEST(TerminalSafe, ControlsAreShownAsVisibleEscapes) {
  EXPECT_EQ(terminal_safe("\x1b[2J\x1b]0;owned\x07"), "\\u001b[2J\\u001b]0;owned\\u0007");
  EXPECT_EQ(terminal_safe("a\nb\tc\rd"), "a\\u000ab\\u0009c\\u000dd");
  EXPECT_EQ(terminal_safe("del\x7f"), "del\\u007f");
  EXPECT_EQ(terminal_safe(std::string("nul\0x", 5)), "nul\\u0000x");
  EXPECT_EQ(terminal_safe("csi\xc2\x9b"
                          "31m"),
            "csi\\u009b31m");  // C1 CSI as UTF-8
  EXPECT_EQ(terminal_safe("back\\slash"), "back\\\\slash");
}

TEST(TerminalSafe, BidiAndInvisibleCharactersAreShown) {
  EXPECT_EQ(terminal_safe("avat\u200bar1"), "avat\\u200bar1");
  EXPECT_EQ(terminal_safe("evil\u202etxt.exe"), "evil\\u202etxt.exe");
  EXPECT_EQ(terminal_safe("\u2066x\u2069"), "\\u2066x\\u2069");
  EXPECT_EQ(terminal_safe("\ufeffbom"), "\\ufeffbom");
  EXPECT_EQ(terminal_safe("soft\u00adhyphen"), "soft\\u00adhyphen");
  EXPECT_EQ(terminal_safe("tag\U000E0041"), "tag\\U000e0041");
  EXPECT_EQ(terminal_safe("line\u2028sep"), "line\\u2028sep");
  for (const char* s : {"avat\u200bar1", "a\u200db", "x\u202e", "\u2060", "\u061c", "\u3164", "v\ufe0f"})
    EXPECT_FALSE(is_safe_name(s)) << terminal_safe(s);
}

TEST(TerminalSafe, BytesThatAreNotUtf8AreShownInHex) {
  EXPECT_EQ(terminal_safe("raw\x9b"
                          "31m"),
            "raw\\x9b31m");  // a lone C1 byte
  EXPECT_EQ(terminal_safe("bad\xff\xfe"), "bad\\xff\\xfe");
  EXPECT_EQ(terminal_safe("over\xc0\xaf"), "over\\xc0\\xaf");                  // overlong '/'
  EXPECT_EQ(terminal_safe("sur\xed\xa0\x80"), "sur\\xed\\xa0\\x80");           // a UTF-16 surrogate
  EXPECT_EQ(terminal_safe("cut\xe2\x82"), "cut\\xe2\\x82");                    // truncated sequence
  EXPECT_EQ(terminal_safe("big\xf4\x90\x80\x80"), "big\\xf4\\x90\\x80\\x80");  // above U+10FFFF
  for (const char* s : {"raw\x9b", "bad\xff", "over\xc0\xaf", "sur\xed\xa0\x80", "cut\xe2\x82"})
    EXPECT_FALSE(is_safe_name(s));
}

// Whatever the bytes, the output is inert and a name that passes is printed as itself.
TEST(TerminalSafe, RandomBytesAlwaysComeOutInert) {
  std::mt19937 rng(18);
  for (int round = 0; round < 20000; ++round) {
    std::string s(rng() % 12, '\0');
    for (char& ch : s) ch = static_cast<char>(rng() % 4 == 0 ? 0x80 + rng() % 64 : rng() % 256);
    const std::string out = terminal_safe(s);
    ASSERT_TRUE(inert(out)) << round;
    if (is_safe_name(s) && s.find('\\') == std::string::npos) {
      EXPECT_EQ(out, s);
    }
  }
}

}  // namespace
}  // namespace mimic::text_test
