#include "runtime/log_prefix.hpp"

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <ctime>
#include <iostream>
#include <map>
#include <mutex>
#include <streambuf>
#include <thread>

namespace sirupp::runtime {

namespace {

std::string Lower(std::string text) {
  std::transform(text.begin(), text.end(), text.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return text;
}

bool StartsWith(const std::string& text, const std::string& start) {
  return text.compare(0, start.size(), start) == 0;
}

bool Contains(const std::string& text, const char* part) {
  return text.find(part) != std::string::npos;
}

}  // namespace

const char* LogLevelName(LogLevel level) {
  switch (level) {
    case LogLevel::kWarn:
      return "warn";
    case LogLevel::kError:
      return "error";
    case LogLevel::kInfo:
      break;
  }
  return "info";
}

std::string FormatLogTime(std::chrono::system_clock::time_point time) {
  const auto since_epoch = time.time_since_epoch();
  const auto seconds = std::chrono::duration_cast<std::chrono::seconds>(since_epoch);
  auto millis =
      std::chrono::duration_cast<std::chrono::milliseconds>(since_epoch - seconds).count();
  std::time_t whole = static_cast<std::time_t>(seconds.count());
  if (millis < 0) {  // before 1970: floor, not truncate
    millis += 1000;
    --whole;
  }
  std::tm local{};
  localtime_r(&whole, &local);
  char text[40];
  const size_t length = std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%S", &local);
  std::snprintf(text + length, sizeof text - length, ".%03d", static_cast<int>(millis));
  return text;
}

LogLevel InferLogLevel(const std::string& message) {
  const std::string text = Lower(message);
  if (StartsWith(text, "error") || StartsWith(text, "fatal") || Contains(text, "error:") ||
      Contains(text, "fault") || Contains(text, "failed") || Contains(text, "cannot ")) {
    return LogLevel::kError;
  }
  if (StartsWith(text, "warn") || Contains(text, "warning") || Contains(text, "refused") ||
      Contains(text, "not granted") || Contains(text, "no answer") || Contains(text, "tripped") ||
      Contains(text, "aborted") || Contains(text, "estop") || Contains(text, "emergency stop")) {
    return LogLevel::kWarn;
  }
  return LogLevel::kInfo;
}

std::string FormatLogLine(std::chrono::system_clock::time_point time, const std::string& name,
                          const std::string& message, LogLevel marked, bool is_marked) {
  std::string text = message;
  if (!name.empty() && StartsWith(text, name + ": ")) text.erase(0, name.size() + 2);
  LogLevel level = is_marked ? marked : InferLogLevel(text);
  // A leading level word moves into the prefix.
  static const std::pair<std::string, LogLevel> kWords[] = {
      {"error: ", LogLevel::kError}, {"warning: ", LogLevel::kWarn}, {"warn: ", LogLevel::kWarn}};
  for (const auto& [word, word_level] : kWords) {
    if (StartsWith(Lower(text.substr(0, word.size())), word)) {
      text.erase(0, word.size());
      if (!is_marked) level = word_level;
      break;
    }
  }
  return FormatLogTime(time) + " " + name + " " + LogLevelName(level) + ": " + text;
}

// A stream buffer that gathers each thread's characters into lines and writes every finished line,
// prefixed, to the stream's original buffer under one lock.
class LogPrefix::Buffer : public std::streambuf {
 public:
  Buffer(std::ostream& stream, std::string name)
      : stream_(stream), name_(std::move(name)), original_(stream.rdbuf()) {
    stream_.rdbuf(this);
  }
  ~Buffer() override {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      for (auto& [thread, line] : lines_) {
        if (!line.text.empty()) Emit(line);
      }
      lines_.clear();
      original_->pubsync();
    }
    stream_.rdbuf(original_);
  }
  Buffer(const Buffer&) = delete;
  Buffer& operator=(const Buffer&) = delete;

  std::streambuf* original() const { return original_; }

  void Mark(LogLevel level) {
    std::lock_guard<std::mutex> lock(mutex_);
    Line& line = lines_[std::this_thread::get_id()];
    line.level = level;
    line.marked = true;
  }

 protected:
  int_type overflow(int_type c) override {
    if (traits_type::eq_int_type(c, traits_type::eof())) return traits_type::not_eof(c);
    const char ch = traits_type::to_char_type(c);
    xsputn(&ch, 1);
    return c;
  }

  std::streamsize xsputn(const char* text, std::streamsize count) override {
    std::lock_guard<std::mutex> lock(mutex_);
    Line& line = lines_[std::this_thread::get_id()];
    for (std::streamsize i = 0; i < count; ++i) {
      if (text[i] == '\n') {
        Emit(line);
      } else {
        line.text += text[i];
      }
    }
    return count;
  }

  // A flush (std::cerr flushes after every <<) writes nothing: lines go out whole at '\n'.
  int sync() override { return 0; }

 private:
  struct Line {
    std::string text;
    LogLevel level = LogLevel::kInfo;
    bool marked = false;
  };

  // Called with mutex_ held.
  void Emit(Line& line) {
    std::string out = line.text.empty() ? std::string()
                                        : FormatLogLine(std::chrono::system_clock::now(), name_,
                                                        line.text, line.level, line.marked);
    out += '\n';
    original_->sputn(out.data(), static_cast<std::streamsize>(out.size()));
    original_->pubsync();
    line = Line{};
  }

  std::ostream& stream_;
  std::string name_;
  std::streambuf* original_;
  std::mutex mutex_;
  std::map<std::thread::id, Line> lines_;
};

LogPrefix::LogPrefix(std::string process_name)
    : out_(std::make_unique<Buffer>(std::cout, process_name)),
      err_(std::make_unique<Buffer>(std::cerr, std::move(process_name))) {}

LogPrefix::~LogPrefix() {
  err_.reset();
  out_.reset();
}

std::streambuf* LogPrefix::original(std::ostream& stream) const {
  if (&stream == &std::cout) return out_->original();
  if (&stream == &std::cerr) return err_->original();
  return stream.rdbuf();
}

namespace {
std::ostream& Mark(std::ostream& stream, LogLevel level) {
  stream.flush();
  if (auto* buffer = dynamic_cast<LogPrefix::Buffer*>(stream.rdbuf())) buffer->Mark(level);
  return stream;
}
}  // namespace

std::ostream& LogWarn(std::ostream& stream) { return Mark(stream, LogLevel::kWarn); }
std::ostream& LogError(std::ostream& stream) { return Mark(stream, LogLevel::kError); }

}  // namespace sirupp::runtime
