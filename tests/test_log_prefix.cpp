// Timestamps and levels on process log lines (runtime/log_prefix.hpp): the time format, the level
// rules, the name and level words moved into the prefix, and the installed buffer writing whole
// lines from several threads.
#include <gtest/gtest.h>

#include <iostream>
#include <regex>
#include <sstream>
#include <thread>
#include <vector>

#include "runtime/log_prefix.hpp"

namespace sirupp::runtime {
namespace {

const std::regex kPrefix(
    R"(^\d{4}-\d{2}-\d{2}T\d{2}:\d{2}:\d{2}\.\d{3} sirupp-test (info|warn|error): .*$)");

TEST(LogPrefix, TimeIsIsoWithMilliseconds) {
  const auto time =
      std::chrono::system_clock::from_time_t(1700000000) + std::chrono::milliseconds(7);
  const std::string text = FormatLogTime(time);
  EXPECT_TRUE(std::regex_match(text, std::regex(R"(\d{4}-\d{2}-\d{2}T\d{2}:\d{2}:\d{2}\.007)")))
      << text;
}

TEST(LogPrefix, LevelsAreInferred) {
  EXPECT_EQ(InferLogLevel("puma260 (6 joints), lockstep"), LogLevel::kInfo);
  EXPECT_EQ(InferLogLevel("stopped: 0 commands, 0 checksum errors, 0 replies"), LogLevel::kInfo);
  EXPECT_EQ(InferLogLevel("error: bad model"), LogLevel::kError);
  EXPECT_EQ(InferLogLevel("FAULT: joint 2 following error"), LogLevel::kError);
  EXPECT_EQ(InferLogLevel("cannot open /dev/ttyUSB0"), LogLevel::kError);
  EXPECT_EQ(InferLogLevel("--rt-priority 50 not granted (Operation not permitted)"),
            LogLevel::kWarn);
  EXPECT_EQ(InferLogLevel("tick 0: no answer from ghost"), LogLevel::kWarn);
  EXPECT_EQ(InferLogLevel("warning: late commands"), LogLevel::kWarn);
  EXPECT_EQ(InferLogLevel("joint j5 tripped its position-error limit; plan aborted"),
            LogLevel::kWarn);
}

TEST(LogPrefix, NameAndLevelWordMoveIntoThePrefix) {
  const auto time = std::chrono::system_clock::now();
  const std::string stamp = FormatLogTime(time);
  EXPECT_EQ(FormatLogLine(time, "sirupp-sim", "sirupp-sim: stopped at tick 3"),
            stamp + " sirupp-sim info: stopped at tick 3");
  EXPECT_EQ(FormatLogLine(time, "sirupp-sim", "sirupp-sim: warning: slow"),
            stamp + " sirupp-sim warn: slow");
  EXPECT_EQ(FormatLogLine(time, "sirupp-sim", "Error: x"), stamp + " sirupp-sim error: x");
  EXPECT_EQ(FormatLogLine(time, "sirupp-sim", "plain", LogLevel::kError, true),
            stamp + " sirupp-sim error: plain");
}

// The installed prefix over a string stream standing in for the terminal.
TEST(LogPrefix, EveryLineOfEveryThreadIsPrefixedAndWhole) {
  std::ostringstream captured_err, captured_out;
  std::streambuf* const err = std::cerr.rdbuf(captured_err.rdbuf());
  std::streambuf* const out = std::cout.rdbuf(captured_out.rdbuf());
  {
    const LogPrefix prefix("sirupp-test");
    std::cerr << "sirupp-test: starting, " << 3 << " threads\n";
    std::vector<std::thread> threads;
    for (int t = 0; t < 3; ++t) {
      threads.emplace_back([t] {
        for (int i = 0; i < 200; ++i) std::cerr << "thread " << t << " line " << i << " end\n";
      });
    }
    for (std::thread& thread : threads) thread.join();
    LogWarn(std::cerr) << "marked by hand\n";
    LogError(std::cerr) << "also by hand\n";
    std::cout << "on stdout\n";
    std::cerr << "unfinished";  // written, with a newline, when the prefix goes
    std::ostream(prefix.original(std::cerr)) << "raw text\n";
  }
  EXPECT_EQ(std::cerr.rdbuf(), captured_err.rdbuf());  // restored
  std::cerr.rdbuf(err);
  std::cout.rdbuf(out);

  std::istringstream lines(captured_err.str());
  std::string line;
  int count = 0, thread_lines = 0;
  std::vector<std::string> all;
  while (std::getline(lines, line)) {
    all.push_back(line);
    if (line == "raw text") continue;
    ++count;
    EXPECT_TRUE(std::regex_match(line, kPrefix)) << line;
    if (line.find(" thread ") != std::string::npos) {
      ++thread_lines;
      EXPECT_TRUE(std::regex_search(line, std::regex(R"(info: thread \d line \d+ end$)"))) << line;
    }
  }
  EXPECT_EQ(thread_lines, 600);
  EXPECT_EQ(count, 1 + 600 + 2 + 1);
  ASSERT_GE(all.size(), 4U);
  EXPECT_NE(all[0].find(" sirupp-test info: starting, 3 threads"), std::string::npos) << all[0];
  const std::string text = captured_err.str();
  EXPECT_NE(text.find(" sirupp-test warn: marked by hand\n"), std::string::npos);
  EXPECT_NE(text.find(" sirupp-test error: also by hand\n"), std::string::npos);
  EXPECT_NE(text.find(" sirupp-test info: unfinished\n"), std::string::npos);
  EXPECT_TRUE(
      std::regex_match(captured_out.str().substr(0, captured_out.str().size() - 1), kPrefix))
      << captured_out.str();
}

}  // namespace
}  // namespace sirupp::runtime
