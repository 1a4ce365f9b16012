#include "core/heartbeat.hpp"

#include <unistd.h>

#include <array>
#include <cmath>
#include <cstdlib>
#include <utility>

#include "core/errors.hpp"
#include "core/translate.hpp"

namespace sirupp::core {
namespace {

std::string HostName() {
  std::array<char, 256> buffer{};
  if (gethostname(buffer.data(), buffer.size() - 1) != 0) return "unknown";
  return std::string(buffer.data());
}

}  // namespace

const char* ProcessStateName(ProcessState state) {
  switch (state) {
    case ProcessState::kStarting:
      return "starting";
    case ProcessState::kRunning:
      return "running";
    case ProcessState::kDegraded:
      return "degraded";
    case ProcessState::kFault:
      return "fault";
    case ProcessState::kStopping:
      return "stopping";
  }
  return "unknown";
}

std::string StartGuardDetail(double left_s) {
  const double hundredths = std::ceil((left_s > 0 ? left_s : 0.0) * 100 - 1e-9);
  return std::string(kStartGuardWord) + ": commands are refused for " +
         FormatApprox(hundredths / 100) + " s more";
}

std::optional<double> StartGuardLeft(const std::string& detail) {
  const std::string head = std::string(kStartGuardWord) + ": commands are refused for ";
  if (detail.rfind(head, 0) != 0) return std::nullopt;
  char* end = nullptr;
  const double left = std::strtod(detail.c_str() + head.size(), &end);
  if (end == detail.c_str() + head.size() || !std::isfinite(left)) return std::nullopt;
  return left;
}

Heartbeat::Heartbeat(Bus& bus, std::string process_name, std::string channel, double period_s)
    : bus_(bus),
      process_(std::move(process_name)),
      channel_(std::move(channel)),
      host_(HostName()),
      pid_(static_cast<int32_t>(getpid())),
      period_(std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(period_s))),
      started_(Clock::now()),
      previous_time_(started_) {}

bool Heartbeat::PublishIfDue(ProcessState state, const std::string& detail) {
  if (!Due()) return false;
  Publish(state, detail);
  return true;
}

void Heartbeat::Publish(ProcessState state, const std::string& detail) {
  const sirupp::heartbeat_t message = Build(state, detail);
  bus_.Publish(channel_, message);
  ++seq_;
  sent_any_ = true;
  last_state_ = state;
  last_sent_ = Clock::now();
}

sirupp::heartbeat_t Heartbeat::Build(ProcessState state, const std::string& detail) {
  const Clock::time_point now = Clock::now();
  const double since_previous = std::chrono::duration<double>(now - previous_time_).count();
  HeartbeatReport report;
  report.utime = WallMicros();
  report.seq = seq_;
  report.process = process_;
  report.host = host_;
  report.pid = pid_;
  report.state = state;
  report.detail = detail;
  report.uptime_s = std::chrono::duration<double>(now - started_).count();
  std::map<std::string, int64_t> counts;
  for (const ChannelStats& stats : bus_.Stats()) {
    ChannelTraffic traffic;
    traffic.stats = stats;
    const std::string key = (stats.publishing ? "tx " : "rx ") + stats.channel;
    const auto previous = previous_counts_.find(key);
    const int64_t before = previous == previous_counts_.end() ? 0 : previous->second;
    traffic.rate_hz =
        since_previous > 0 ? static_cast<double>(stats.messages - before) / since_previous : 0.0;
    counts[key] = stats.messages;
    report.channels.push_back(std::move(traffic));
  }
  previous_counts_ = std::move(counts);
  previous_time_ = now;
  return ToMessage(report);
}

}  // namespace sirupp::core
