#pragma once
// Timestamps and levels on every process's log lines. ProcessMain (process_main.hpp) installs a
// LogPrefix over std::cerr and std::cout for the whole run, so every existing `std::cerr << ...`
// line of a process comes out as
//
//   2026-11-24T10:15:03.123 sirupp-sim warn: message
//
// local time with milliseconds, the process name, the level (info, warn or error). A line that
// already starts with "NAME: " loses that part (the prefix names the process), and a leading
// "error: " or "warning: " becomes the level. Otherwise the level is inferred from the text
// (InferLogLevel), or set for the next line with LogWarn() / LogError(). Lines are written whole,
// one at a time, even when several threads write (each thread's characters gather in a line of
// its own). Output through C stdio (printf, fprintf) is not prefixed. docs/logging.md.

#include <chrono>
#include <memory>
#include <ostream>
#include <string>

namespace sirupp::runtime {

enum class LogLevel { kInfo, kWarn, kError };
const char* LogLevelName(LogLevel level);

// "2026-11-24T10:15:03.123", local time.
std::string FormatLogTime(std::chrono::system_clock::time_point time);

// The level a message (without the process name) reads as: error when it starts with "error" or
// "fatal" or mentions "error:", a fault, "failed" or "cannot"; warn when it starts with "warn" or
// mentions a warning, "refused", "not granted", "no answer", "tripped", "aborted" or an
// emergency stop; else info.
LogLevel InferLogLevel(const std::string& message);

// The whole prefixed line (without the newline) for `message` written by process `name`.
std::string FormatLogLine(std::chrono::system_clock::time_point time, const std::string& name,
                          const std::string& message, LogLevel marked = LogLevel::kInfo,
                          bool is_marked = false);

// While alive, std::cout and std::cerr prefix every line as above; on destruction any unfinished
// line is written (with a newline) and the streams get their own buffers back. One at a time.
class LogPrefix {
 public:
  explicit LogPrefix(std::string process_name);
  ~LogPrefix();
  LogPrefix(const LogPrefix&) = delete;
  LogPrefix& operator=(const LogPrefix&) = delete;

  // The stream's buffer before the prefix was installed (to print text that is not a log line,
  // such as a usage text).
  std::streambuf* original(std::ostream& stream) const;

  class Buffer;  // the line-prefixing stream buffer (log_prefix.cpp)

 private:
  std::unique_ptr<Buffer> out_, err_;
};

// Marks the next line this thread writes to `stream` as a warning or an error; returns `stream`.
// Without a LogPrefix installed it only returns `stream`.
std::ostream& LogWarn(std::ostream& stream);
std::ostream& LogError(std::ostream& stream);

}  // namespace sirupp::runtime
