#pragma once
// `sirupp replay LOG [--speed X] [--lcm-url URL]`: plays an lcm-logger file back onto the bus with
// its original timing (scaled by --speed), through LCM's own log reader (lcm::LogFile).

#include <cstdint>
#include <functional>
#include <iosfwd>
#include <string>
#include <vector>

namespace lcm {
class LCM;
}

namespace sirupp::tools {

extern const char* const kReplayAbout;

struct ReplayStats {
  int64_t events = 0;       // messages published
  int64_t channels = 0;     // distinct channels among them
  double log_span_s = 0;    // first to last event in the log
  double wall_s = 0;        // how long the replay took
  double worst_late_s = 0;  // largest delay of a publication behind its scaled log time
  bool stopped = false;     // stop() asked to end early
};

// Publishes every event of the lcm-logger file `path` on `lcm`, in order, event k at
// (timestamp_k - timestamp_0) / speed after the first (speed > 0). Checks `stop` between events
// and while waiting. Throws std::runtime_error when the file cannot be opened or read.
ReplayStats ReplayLog(const std::string& path, lcm::LCM& lcm, double speed,
                      const std::function<bool()>& stop);

int RunReplay(const std::vector<std::string>& args, std::ostream& out);

}  // namespace sirupp::tools
