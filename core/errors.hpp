#pragma once
// Error types thrown at the edges (config files, messages, command lines). Each carries where the
// bad input is, so that main can print one line a user can act on. Inside per-tick loops we return
// status instead of throwing.

#include <stdexcept>
#include <string>

namespace sirupp::core {

// A place in a text file; line and column count from 1, 0 = unknown.
struct SourceLocation {
  std::string file;
  int line = 0;
  int column = 0;

  // "file:line:column", "file:line" or "file" depending on what is known.
  std::string ToString() const;
};

// Bad configuration (model, plan, environment, lab layout). what() is
// "file:line:col: key.path: problem", the form compilers use, so editors can jump to it.
class ConfigError : public std::runtime_error {
 public:
  ConfigError(SourceLocation where, std::string key_path, std::string problem);

  const SourceLocation& where() const { return where_; }
  const std::string& key_path() const { return key_path_; }
  const std::string& problem() const { return problem_; }

 private:
  SourceLocation where_;
  std::string key_path_;
  std::string problem_;
};

// A received message that decoded but holds values we refuse. what() is
// "channel CHANNEL: field.path: problem" ("channel CHANNEL: problem" when the whole message is
// refused, e.g. a target in automatic mode).
class MessageError : public std::runtime_error {
 public:
  MessageError(std::string channel, std::string field_path, std::string problem);

  const std::string& channel() const { return channel_; }
  const std::string& field_path() const { return field_path_; }

 private:
  std::string channel_;
  std::string field_path_;
};

// Bad command-line arguments: main prints what() and the usage hint, and exits with code 2.
class UsageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Shortest text that reads back as the same double ("0.1", "1e-09", "nan").
std::string FormatNumber(double value);
// A computed value for people: 6 significant digits ("0.0125", "1.74533").
std::string FormatApprox(double value);

}  // namespace sirupp::core
