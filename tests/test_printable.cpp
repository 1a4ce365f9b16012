// core::Printable: user text made safe for one-line error messages.
#include <gtest/gtest.h>

#include <string>

#include "core/printable.hpp"

namespace sirupp::core {
namespace {

TEST(Printable, PlainTextAndUtf8AreUnchanged) {
  EXPECT_EQ(Printable("move j1=90 # ok"), "move j1=90 # ok");
  EXPECT_EQ(Printable("Gelenk 90° 日本 \xF0\x9F\xA4\x96"), "Gelenk 90° 日本 \xF0\x9F\xA4\x96");
  EXPECT_TRUE(IsPrintable("Gelenk 90°"));
  EXPECT_EQ(Printable(""), "");
}

TEST(Printable, ControlCharactersAreEscaped) {
  EXPECT_EQ(Printable(std::string("a\x00"
                                  "b\tc\r\n\x1b[2J\x7f",
                                  12)),
            "a\\x00b\\x09c\\x0D\\x0A\\x1B[2J\\x7F");
  EXPECT_EQ(Printable("\xC2\x85"), "\\xC2\\x85");  // C1 control (NEL)
  EXPECT_EQ(Printable("ab\xE2\x80\xAE"
                      "cd"),
            "ab\\xE2\\x80\\xAEcd");                                 // right-to-left override
  EXPECT_EQ(Printable("\xE2\x80\xA8"), "\\xE2\\x80\\xA8");          // line separator
  EXPECT_EQ(Printable("\xEF\xBB\xBFmove"), "\\xEF\\xBB\\xBFmove");  // invisible: byte-order mark
  EXPECT_EQ(Printable("a\xE2\x80\x8B"), "a\\xE2\\x80\\x8B");        // zero-width space
  EXPECT_FALSE(IsPrintable("tab\there"));
}

TEST(Printable, BytesThatAreNotUtf8AreEscapedOneByOne) {
  EXPECT_EQ(Printable("\xFF\xFE"), "\\xFF\\xFE");
  EXPECT_EQ(Printable("\x80x"), "\\x80x");                           // stray continuation byte
  EXPECT_EQ(Printable("\xC0\x80"), "\\xC0\\x80");                    // overlong NUL
  EXPECT_EQ(Printable("\xED\xA0\x80"), "\\xED\\xA0\\x80");           // UTF-16 surrogate
  EXPECT_EQ(Printable("\xE2\x82"), "\\xE2\\x82");                    // cut short at the end
  EXPECT_EQ(Printable("\xF4\x90\x80\x80"), "\\xF4\\x90\\x80\\x80");  // above U+10FFFF
  EXPECT_FALSE(IsPrintable("\xFF"));
}

TEST(Printable, LongTextIsCutAfterMaxChars) {
  EXPECT_EQ(Printable("abcdef", 3), "abc...");
  EXPECT_EQ(Printable("abc", 3), "abc");
  EXPECT_EQ(Printable("\x01\x02\x03\x04", 2), "\\x01\\x02...");  // an escape is one character
  EXPECT_EQ(Printable("°°°°", 2), "°°...");
}

}  // namespace
}  // namespace sirupp::core
