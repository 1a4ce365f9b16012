#include "tools/replay_commands.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <lcm/lcm-cpp.hpp>
#include <ostream>
#include <set>
#include <stdexcept>
#include <thread>

#include "core/errors.hpp"
#include "runtime/args.hpp"
#include "runtime/process_main.hpp"

namespace sirupp::tools {

const char* const kReplayAbout =
    "  Plays an LCM log file (as lcm-logger writes it) back onto the bus: every message on its\n"
    "  channel, in order, with the gaps between them as recorded, divided by --speed (default 1;\n"
    "  2 = twice as fast, 0.5 = half speed). --lcm-url: where to publish (default LCM's default\n"
    "  URL). Ctrl-C stops early. Prints one summary line.\n"
    "  Exit code 0 when played, 1 when the file cannot be read, 2 for bad arguments.\n";

ReplayStats ReplayLog(const std::string& path, lcm::LCM& lcm, double speed,
                      const std::function<bool()>& stop) {
  if (!(speed > 0)) throw std::invalid_argument("replay: speed must be > 0");
  lcm::LogFile log(path, "r");
  if (!log.good()) throw std::runtime_error("replay: cannot open LCM log '" + path + "'");

  using Clock = std::chrono::steady_clock;
  ReplayStats stats;
  std::set<std::string> channels;
  int64_t first_us = 0;
  int64_t last_us = 0;
  Clock::time_point start;
  while (const lcm::LogEvent* event = log.readNextEvent()) {
    if (stats.events == 0) {
      first_us = event->timestamp;
      start = Clock::now();
    }
    last_us = event->timestamp;
    const auto due =
        start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(
                    static_cast<double>(event->timestamp - first_us) * 1e-6 / speed));
    // Wait in slices, so that a stop request is seen within 50 ms.
    for (auto now = Clock::now(); now < due; now = Clock::now()) {
      if (stop && stop()) break;
      std::this_thread::sleep_until(std::min(due, now + std::chrono::milliseconds(50)));
    }
    if (stop && stop()) {
      stats.stopped = true;
      break;
    }
    stats.worst_late_s =
        std::max(stats.worst_late_s, std::chrono::duration<double>(Clock::now() - due).count());
    if (lcm.publish(event->channel, event->data, static_cast<unsigned int>(event->datalen)) != 0) {
      throw std::runtime_error("replay: publishing on " + event->channel + " failed");
    }
    channels.insert(event->channel);
    ++stats.events;
  }
  if (stats.events > 0) {
    stats.log_span_s = static_cast<double>(last_us - first_us) * 1e-6;
    stats.wall_s = std::chrono::duration<double>(Clock::now() - start).count();
  }
  stats.channels = static_cast<int64_t>(channels.size());
  return stats;
}

int RunReplay(const std::vector<std::string>& raw, std::ostream& out) {
  const runtime::Args args(raw, "replay",
                           {runtime::Flag("log", "an lcm-logger file").Positional("LOG"),
                            runtime::Flag("speed", "playback speed").Takes("X").Above(0),
                            runtime::Flag("lcm-url", "LCM URL").Takes("URL")},
                           kReplayAbout);
  const std::string path = args.String("log");
  const double speed = args.Number("speed", 1.0);
  const std::string url = args.Has("lcm-url") ? args.String("lcm-url") : "";
  lcm::LCM lcm(url);
  if (!lcm.good()) throw std::runtime_error("replay: cannot open LCM URL '" + url + "'");
  runtime::InstallStopHandlers();
  const ReplayStats stats = ReplayLog(path, lcm, speed, runtime::StopRequested);
  char line[256];
  std::snprintf(line, sizeof line,
                "replay: %lld messages on %lld channels, log span %.3f s played in %.3f s at "
                "speed %g%s\n",
                static_cast<long long>(stats.events), static_cast<long long>(stats.channels),
                stats.log_span_s, stats.wall_s, speed, stats.stopped ? " (stopped early)" : "");
  out << line;
  return 0;
}

}  // namespace sirupp::tools
