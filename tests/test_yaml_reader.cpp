#include <gtest/gtest.h>

#include <chrono>
#include <string>

#include "core/yaml_reader.hpp"
#include "tests/helpers.hpp"

namespace sirupp::core {
namespace {

using sirupp::testing::ErrorText;

// Runs `body` and returns the ConfigError text it throws ("" if none).
TEST(YamlReader, ReadsNumbersWithRules) {
  const YamlDocument doc = YamlDocument::Parse("mass: 2.5\nspeed: -1\n", "t.yaml");
  const YamlMap map = doc.Root().Map({"mass", "speed"});
  EXPECT_DOUBLE_EQ(map.Number("mass", PositiveNumber("kg")), 2.5);
  EXPECT_EQ(ErrorText<ConfigError>([&] { map.Number("speed", NonNegativeNumber("m/s")); }),
            "t.yaml:2:8: speed: -1 is not allowed; expected a finite number >= 0 (m/s)");
}

TEST(YamlReader, DescribesRanges) {
  EXPECT_EQ(NumberInRange(0, 1, "x").Describe(), "a finite number in [0, 1] (x)");
  EXPECT_EQ(PositiveNumber().Describe(), "a finite number > 0");
  EXPECT_EQ(AnyNumber("m").Describe(), "a finite number (m)");
  EXPECT_FALSE(AnyNumber().Allows(std::numeric_limits<double>::quiet_NaN()));
}

TEST(YamlReader, UnknownKeyNamesAllowedOnes) {
  const YamlDocument doc = YamlDocument::Parse("a: 1\nb: 2\n", "t.yaml");
  EXPECT_EQ(ErrorText<ConfigError>([&] { doc.Root().Map({"a"}); }),
            "t.yaml:2:1: b: unknown key 'b'; allowed keys: a");
}

TEST(YamlReader, DuplicateKeyIsAnError) {
  const YamlDocument doc = YamlDocument::Parse("a: 1\na: 2\n", "t.yaml");
  EXPECT_EQ(ErrorText<ConfigError>([&] { doc.Root().Map({"a"}); }),
            "t.yaml:2:1: a: duplicate key 'a'; each key may appear once");
}

TEST(YamlReader, MissingKeyPointsAtTheMapping) {
  const YamlDocument doc = YamlDocument::Parse("outer:\n  a: 1\n", "t.yaml");
  const YamlMap outer = doc.Root().Map({"outer"}).Get("outer", "a mapping").Map({"a", "b"});
  EXPECT_EQ(ErrorText<ConfigError>([&] { outer.Number("b", AnyNumber("s")); }),
            "t.yaml:2:3: outer: missing required key 'b' (a finite number (s))");
}

TEST(YamlReader, QuotedNumbersAreText) {
  const YamlDocument doc = YamlDocument::Parse("a: \"3\"\n", "t.yaml");
  EXPECT_EQ(ErrorText<ConfigError>([&] { doc.Root().Map({"a"}).Number("a", AnyNumber()); }),
            "t.yaml:1:4: a: the text \"3\" is not a number; expected a finite number");
}

TEST(YamlReader, NonFiniteNumbersAreRefused) {
  const YamlDocument doc = YamlDocument::Parse("a: .nan\nb: -.inf\nc: 1e999\n", "t.yaml");
  const YamlMap map = doc.Root().Map({"a", "b", "c"});
  EXPECT_NE(
      ErrorText<ConfigError>([&] { map.Number("a", AnyNumber()); }).find(".nan is not allowed"),
      std::string::npos);
  EXPECT_NE(
      ErrorText<ConfigError>([&] { map.Number("b", AnyNumber()); }).find("-.inf is not allowed"),
      std::string::npos);
  EXPECT_NE(
      ErrorText<ConfigError>([&] { map.Number("c", AnyNumber()); }).find("1e999 is not allowed"),
      std::string::npos);
}

TEST(YamlReader, ListsHaveIndexedPaths) {
  const YamlDocument doc = YamlDocument::Parse("v: [1, 2, x]\n", "t.yaml");
  EXPECT_EQ(
      ErrorText<ConfigError>([&] { doc.Root().Map({"v"}).Get("v", "").Numbers(3, AnyNumber()); }),
      "t.yaml:1:11: v[2]: x is not a number; expected a finite number");
}

TEST(YamlReader, MergeKeysResolveWithOverrides) {
  const YamlDocument doc = YamlDocument::Parse(
      "base: &b {kp: 100, kd: 1000}\n"
      "mid: &m {<<: *b, kd: 5}\n"
      "top: {<<: *m, kp: 7}\n",
      "t.yaml");
  const YamlMap root = doc.Root().Map({"base", "mid", "top"});
  const YamlMap top = root.Get("top", "").Map({"kp", "kd"});
  EXPECT_DOUBLE_EQ(top.Number("kp", AnyNumber()), 7);
  EXPECT_DOUBLE_EQ(top.Number("kd", AnyNumber()), 5);
  const YamlMap mid = root.Get("mid", "").Map({"kp", "kd"});
  EXPECT_DOUBLE_EQ(mid.Number("kp", AnyNumber()), 100);
}

TEST(YamlReader, MergedUnknownKeyPointsIntoTheAnchor) {
  const YamlDocument doc = YamlDocument::Parse("a: &x {kq: 1}\nb: {<<: *x}\n", "t.yaml");
  const YamlMap root = doc.Root().Map({"a", "b"});
  EXPECT_EQ(ErrorText<ConfigError>([&] { root.Get("b", "").Map({"kp"}); }),
            "t.yaml:1:8: b.kq: unknown key 'kq'; allowed keys: kp");
}

TEST(YamlReader, EntriesKeepFileOrder) {
  const YamlDocument doc = YamlDocument::Parse("poses: {zero: [0], up: [1]}\n", "t.yaml");
  const auto entries = doc.Root().Map({"poses"}).Get("poses", "").Entries();
  ASSERT_EQ(entries.size(), 2U);
  EXPECT_EQ(entries[0].first, "zero");
  EXPECT_EQ(entries[1].second.path(), "poses.up");
}

TEST(YamlReader, SyntaxErrorsHaveALine) {
  EXPECT_EQ(ErrorText<ConfigError>([] {
              YamlDocument::Parse("a: [1, 2\nb: 3\n", "t.yaml");
            }).substr(0, 9),
            "t.yaml:2:");
}

TEST(YamlReader, LocationOfFallsBackToParent) {
  const YamlDocument doc = YamlDocument::Parse("x: 1\nlist:\n  - {a: 1}\n", "t.yaml");
  const YamlMap root = doc.Root().Map({"x", "list"});
  root.Get("list", "").Sequence()[0].Map({"a"});
  EXPECT_EQ(doc.LocationOf("list[0].b").ToString(), "t.yaml:3:5");
  EXPECT_EQ(doc.LocationOf("nowhere").ToString(), "t.yaml:1:1");
}

TEST(YamlReader, ControlCharactersInEchoedTextAreEscaped) {
  const YamlDocument doc = YamlDocument::Parse("\"a\\x1bb\": 1\nc: \"\\x07\\u202e1\"\n", "t.yaml");
  EXPECT_EQ(ErrorText<ConfigError>([&] { doc.Root().Map({"c"}); }),
            "t.yaml:1:1: a\\x1Bb: unknown key 'a\\x1Bb'; allowed keys: c");
  const YamlDocument quoted = YamlDocument::Parse("c: \"\\x07\\u202e1\"\n", "t.yaml");
  EXPECT_EQ(ErrorText<ConfigError>([&] { quoted.Root().Map({"c"}).Number("c", AnyNumber()); }),
            "t.yaml:1:4: c: the text \"\\x07\\xE2\\x80\\xAE1\" is not a number; expected a finite "
            "number");
}

// Ten lines that expand nine-fold per line: 9^8 copies of the first line if read naively.
std::string Bomb(bool merge_keys) {
  std::string text = merge_keys ? "a: &a {x: 1, y: 2}\n" : "a: &a [lol, lol, lol, lol]\n";
  for (char name = 'b'; name <= 'i'; ++name) {
    const char previous = static_cast<char>(name - 1);
    std::string refs;
    for (int k = 0; k < 9; ++k) refs += std::string(k ? ", " : "") + "*" + previous;
    text += std::string(1, name) + ": &" + name + (merge_keys ? " {<<: [" : " [") + refs +
            (merge_keys ? "]}\n" : "]\n");
  }
  return text + (merge_keys ? "<<: *i\n" : "j: *i\n");
}

// The refusal names the file, a line inside the bomb and the limit, and comes quickly (the
// generous bound is the point of the test: without the budget this took minutes).
void ExpectBombRefused(const std::string& text, const std::string& expected_start) {
  const auto start = std::chrono::steady_clock::now();
  const std::string error = ErrorText<ConfigError>([&] {
    const YamlDocument doc = YamlDocument::Parse(text, "bomb.yaml");
    doc.Root().Map({"a", "b", "c", "d", "e", "f", "g", "h", "i", "j"});
  });
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_EQ(error.substr(0, expected_start.size()), expected_start) << error;
  EXPECT_NE(error.find("more than 250000 nodes"), std::string::npos) << error;
  EXPECT_NE(error.find("allowed at most 250000"), std::string::npos) << error;
  EXPECT_LT(seconds, 1.0);
}

TEST(YamlReader, AliasBombIsRefusedQuickly) { ExpectBombRefused(Bomb(false), "bomb.yaml:6:4: f["); }

TEST(YamlReader, MergeKeyBombIsRefusedQuickly) {
  ExpectBombRefused(Bomb(true), "bomb.yaml:6:12: f.<<[");
}

TEST(YamlReader, RecursiveAliasIsRefused) {
  EXPECT_EQ(ErrorText<ConfigError>([] { YamlDocument::Parse("a: &a {x: 1, <<: *a}\n", "t.yaml"); }),
            "t.yaml:1:14: a.<<: the document nests more than 100 levels deep (counting aliases as "
            "copies); allowed at most 100");
}

TEST(YamlReader, ModestAliasUseIsFine) {
  // 9 x 9 x 9 x 4 = 2916 expanded scalars: far below the budget.
  const YamlDocument doc = YamlDocument::Parse(
      "a: &a [1, 2, 3, 4]\nb: &b [*a, *a, *a, *a, *a, *a, *a, *a, *a]\n"
      "c: &c [*b, *b, *b, *b, *b, *b, *b, *b, *b]\nd: [*c, *c, *c, *c, *c, *c, *c, *c, *c]\n",
      "t.yaml");
  EXPECT_EQ(doc.Root().Map({"a", "b", "c", "d"}).Get("d", "").Sequence().size(), 9U);
}

}  // namespace
}  // namespace sirupp::core
