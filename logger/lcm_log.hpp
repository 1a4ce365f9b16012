#pragma once
// A reader of LCM's log file format (what lcm-logger writes; docs/logging.md, "LCM log files").
// Each event: u32 sync word 0xEDA1DA01, u64 event number, u64 timestamp (microseconds, the
// logger's receive time), u32 channel length, u32 data length, the channel (no NUL), the data
// (an encoded message, fingerprint first). All integers big-endian; no file header.
//
// Strict where LCM's own reader gives up silently: a bad sync word or impossible lengths inside
// the file throw core::ConfigError "FILE: byte OFFSET (event N): problem". Only a last event cut
// short by the end of the file (a recorder killed mid-write) is tolerated, as a note.

#include <cstdint>
#include <fstream>
#include <string>
#include <vector>

namespace sirupp::logger {

inline constexpr uint32_t kLcmLogSyncWord = 0xEDA1DA01;

struct LcmLogEvent {
  int64_t number = 0;
  int64_t timestamp_us = 0;
  std::string channel;
  std::vector<uint8_t> data;
  int64_t offset = 0;  // byte offset of the event's sync word in the file
  int64_t index = 0;   // 0 for the file's first event, then +1 (event numbers may skip)
};

// True when the file starts with the event sync word.
bool LooksLikeLcmLog(const std::string& path);

class LcmLogReader {
 public:
  // Throws core::ConfigError if the file cannot be opened or does not start with an event.
  explicit LcmLogReader(const std::string& path);

  // The next event; false at the end of the file.
  bool Next(LcmLogEvent& event);

  const std::string& path() const { return path_; }
  const std::vector<std::string>& notes() const { return notes_; }

 private:
  [[noreturn]] void Fail(int64_t offset, const std::string& problem) const;

  std::string path_;
  std::ifstream in_;
  int64_t size_ = 0;
  int64_t offset_ = 0;
  int64_t events_ = 0;
  std::vector<std::string> notes_;
};

}  // namespace sirupp::logger
