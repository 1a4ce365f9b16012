#include "logger/lcm_log.hpp"

#include <cstdio>

#include "core/errors.hpp"
#include "core/printable.hpp"

namespace sirupp::logger {

namespace {

constexpr int64_t kHeaderBytes = 28;
constexpr uint32_t kMaxChannelBytes = 255;              // LCM allows 63; leave room, refuse junk
constexpr uint32_t kMaxDataBytes = 256u * 1024 * 1024;  // no SIRUPP message comes near this

uint64_t BigEndian(const unsigned char* bytes, int count) {
  uint64_t value = 0;
  for (int i = 0; i < count; ++i) value = (value << 8) | bytes[i];
  return value;
}

std::string Hex32(uint32_t value) {
  char text[16];
  std::snprintf(text, sizeof text, "0x%08X", value);
  return text;
}

}  // namespace

bool LooksLikeLcmLog(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  unsigned char bytes[4];
  if (!in.read(reinterpret_cast<char*>(bytes), 4)) return false;
  return BigEndian(bytes, 4) == kLcmLogSyncWord;
}

LcmLogReader::LcmLogReader(const std::string& path) : path_(path), in_(path, std::ios::binary) {
  if (!in_) throw core::ConfigError(core::SourceLocation{path, 0, 0}, "", "cannot open the file");
  in_.seekg(0, std::ios::end);
  size_ = static_cast<int64_t>(in_.tellg());
  in_.seekg(0);
  if (size_ == 0) Fail(0, "the file is empty; expected an LCM log");
  if (!LooksLikeLcmLog(path)) Fail(0, "not an LCM log: no event sync word 0xEDA1DA01 at byte 0");
}

void LcmLogReader::Fail(int64_t offset, const std::string& problem) const {
  throw core::ConfigError(
      core::SourceLocation{path_, 0, 0},
      "byte " + std::to_string(offset) + " (event " + std::to_string(events_) + ")",
      core::Printable(problem));
}

bool LcmLogReader::Next(LcmLogEvent& event) {
  if (offset_ >= size_) return false;
  const int64_t start = offset_;
  unsigned char header[kHeaderBytes];
  const int64_t available = size_ - offset_;
  if (available < kHeaderBytes) {
    notes_.push_back(path_ + ": byte " + std::to_string(start) +
                     ": the last event's header is cut short (" + std::to_string(available) +
                     " of 28 bytes; the recorder stopped while writing it); ignored");
    offset_ = size_;
    return false;
  }
  in_.seekg(start);
  in_.read(reinterpret_cast<char*>(header), kHeaderBytes);
  const auto sync = static_cast<uint32_t>(BigEndian(header, 4));
  if (sync != kLcmLogSyncWord) {
    Fail(start, "expected the event sync word 0xEDA1DA01, found " + Hex32(sync) +
                    ": the log is corrupted here");
  }
  const auto number = static_cast<int64_t>(BigEndian(header + 4, 8));
  const auto timestamp = static_cast<int64_t>(BigEndian(header + 12, 8));
  const auto channel_bytes = static_cast<uint32_t>(BigEndian(header + 20, 4));
  const auto data_bytes = static_cast<uint32_t>(BigEndian(header + 24, 4));
  if (channel_bytes == 0 || channel_bytes > kMaxChannelBytes) {
    Fail(start, "channel length " + std::to_string(channel_bytes) +
                    " is not allowed (1 to 255): the log is corrupted here");
  }
  if (data_bytes > kMaxDataBytes) {
    Fail(start, "data length " + std::to_string(data_bytes) +
                    " is beyond any message (256 MiB at most): the log is corrupted here");
  }
  const int64_t total = kHeaderBytes + channel_bytes + data_bytes;
  if (total > available) {
    notes_.push_back(path_ + ": byte " + std::to_string(start) + " (event " +
                     std::to_string(events_) + "): the last event is cut short (" +
                     std::to_string(available) + " of " + std::to_string(total) +
                     " bytes; the recorder stopped while writing it); ignored");
    offset_ = size_;
    return false;
  }
  event.offset = start;
  event.index = events_;
  event.number = number;
  event.timestamp_us = timestamp;
  event.channel.resize(channel_bytes);
  in_.read(event.channel.data(), channel_bytes);
  event.data.resize(data_bytes);
  if (data_bytes > 0) in_.read(reinterpret_cast<char*>(event.data.data()), data_bytes);
  if (!in_) Fail(start, "read error");
  for (char c : event.channel) {
    if (static_cast<unsigned char>(c) < 0x20 || static_cast<unsigned char>(c) > 0x7e) {
      Fail(start, "the channel name has a non-printable byte: the log is corrupted here");
    }
  }
  offset_ = start + total;
  ++events_;
  return true;
}

}  // namespace sirupp::logger
