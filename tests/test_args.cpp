// runtime/args and runtime/app_format: each flag declared once feeds the parser, the checks and
// the --help text; bad arguments throw UsageError naming the command, the flag and what is allowed.

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "core/errors.hpp"
#include "runtime/app_format.hpp"
#include "runtime/args.hpp"
#include "tests/helpers.hpp"

namespace {

using sirupp::runtime::Args;
using sirupp::runtime::Flag;

std::vector<Flag> DemoLikeFlags() {
  return {Flag("out", "folder").Takes("DIR"),
          Flag("sets", "movement sets").Takes("N", -1),
          Flag("rate", "frames per second").Takes("HZ").Above(0, 240),
          Flag("jobs", "parallel tasks").Takes("N").Integer(1, 64),
          Flag("split", "files").Takes("MODE").OneOf({"plan", "none"}),
          Flag("dry-run", "start nothing").Switch()};
}

// The message of the UsageError `parse` throws ("" if none).
template <typename F>
std::string UsageMessage(F parse) {
  return sirupp::testing::ErrorText<sirupp::core::UsageError>(parse);
}

TEST(Args, OneOrMoreValuesRunUntilTheNextFlag) {
  const Args args({"--sets", "1", "VII", "--out=r", "--dry-run"}, "demo", DemoLikeFlags());
  EXPECT_EQ(args.Values("sets", -1), (std::vector<std::string>{"1", "VII"}));
  EXPECT_EQ(args.String("out"), "r");
  EXPECT_TRUE(args.Switch("dry-run"));
  EXPECT_FALSE(args.Has("rate"));
}

TEST(Args, NegativeNumbersAreValues) {
  const Args args({"--rate", "12.5", "--jobs", "3"}, "demo", DemoLikeFlags());
  EXPECT_DOUBLE_EQ(args.Number("rate", 0), 12.5);
  EXPECT_EQ(args.Integer("jobs", 1), 3);
  const Args joints({"--q", "-1.5", "2"}, "move", {Flag("q", "joints").Takes("Q", -1)});
  EXPECT_EQ(joints.Numbers("q", 2), (std::vector<double>{-1.5, 2}));
}

TEST(Args, DeclaredChecksNameTheFlagTheValueAndWhatIsAllowed) {
  const std::string range = UsageMessage([] {
    Args({"--rate", "500"}, "sirupp-panel", DemoLikeFlags());
  });
  EXPECT_NE(range.find("--rate"), std::string::npos) << range;
  EXPECT_NE(range.find("500"), std::string::npos) << range;
  EXPECT_NE(range.find("240"), std::string::npos) << range;
  const std::string whole = UsageMessage([] { Args({"--jobs", "2.5"}, "grade", DemoLikeFlags()); });
  EXPECT_NE(whole.find("--jobs"), std::string::npos) << whole;
  EXPECT_NE(whole.find("whole number"), std::string::npos) << whole;
  const std::string choice = UsageMessage([] {
    Args({"--split", "day"}, "sirupp-logger", DemoLikeFlags());
  });
  EXPECT_NE(choice.find("'day'"), std::string::npos) << choice;
  EXPECT_NE(choice.find("plan"), std::string::npos) << choice;
  const std::string unknown = UsageMessage([] {
    Args({"--colour", "red"}, "demo", DemoLikeFlags());
  });
  EXPECT_NE(unknown.find("--colour"), std::string::npos) << unknown;
  const std::string missing = UsageMessage([] { Args({"--out"}, "demo", DemoLikeFlags()); });
  EXPECT_NE(missing.find("--out"), std::string::npos) << missing;
}

TEST(Args, HelpListsEveryDeclaredFlagWithItsHelp) {
  std::string text;
  try {
    Args({"--help"}, "demo", DemoLikeFlags(), "Runs the sets.\n");
  } catch (const sirupp::runtime::HelpRequested& help) {
    text = help.text;
  }
  ASSERT_FALSE(text.empty());
  for (const char* expected :
       {"usage: sirupp demo", "Runs the sets.", "--out DIR", "folder", "--sets N ...",
        "movement sets", "--dry-run", "start nothing", "--split MODE", "plan", "--version"}) {
    EXPECT_NE(text.find(expected), std::string::npos) << expected << " in:\n" << text;
  }
}

TEST(AppFormat, ProseIsRefilledAndTableRowsKeepTheirColumns) {
  const std::string about =
      "The main job: the paper's experiment, headless. Starts the processes and runs the\n"
      "movement sets.\n"
      "  --lcm-url URL   the bus (default: a private udpm port with ttl=0, so a lab's traffic and\n"
      "                  other demos never mix)\n"
      "  --dry-run       start nothing\n"
      "Exit: 0 every set ran.\n";
  const std::string wrapped = sirupp::runtime::Wrap(about, 80);
  EXPECT_EQ(wrapped,
            "The main job: the paper's experiment, headless. Starts the processes and runs\n"
            "the movement sets.\n"
            "  --lcm-url URL   the bus (default: a private udpm port with ttl=0, so a lab's\n"
            "                  traffic and other demos never mix)\n"
            "  --dry-run       start nothing\n"
            "Exit: 0 every set ran.");
  for (size_t start = 0, end = 0; start < wrapped.size(); start = end + 1) {
    end = wrapped.find('\n', start);
    if (end == std::string::npos) end = wrapped.size();
    EXPECT_LE(end - start, 80u) << wrapped.substr(start, end - start);
  }
}

}  // namespace
