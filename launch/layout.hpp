#pragma once
// A lab layout (config/labs/*.yaml): which processes run on which host, in which order, with which
// LCM URL and channel prefix, and what to do when one ends. Read strictly: a bad file is one
// core::ConfigError naming file:line, the key, the bad value and what is allowed. The format is
// described in docs/launch.md.

#include <string>
#include <vector>

namespace sirupp::launch {

enum class Restart { kNever, kOnFailure, kAlways };
enum class Ready { kHeartbeat, kStarted, kFile };

struct ProcessSpec {
  std::string name;                  // unique in the layout; names the log file and table row
  std::string host;                  // which host of the layout runs it
  std::vector<std::string> command;  // program and arguments, ${VARIABLES} not yet replaced
  bool lcm = true;                   // append --lcm-url URL --prefix PREFIX of the layout
  Ready ready = Ready::kHeartbeat;   // when the next process may start
  std::string ready_file;            // Ready::kFile: this path exists
  double ready_timeout_s = 20;
  Restart restart = Restart::kNever;
  int max_restarts = 3;
  bool critical = false;      // its end (and no restart left) stops the whole host
  double stop_timeout_s = 5;  // after SIGINT, before SIGKILL
  int line = 0;               // where the entry starts in the file, for messages
};

struct Layout {
  std::string file;
  std::string lab;                 // the layout's name
  std::string description;         // one or two lines for people
  std::string lcm_url;             // empty: LCM's default
  std::string prefix;              // channel prefix, e.g. "RIG3_"
  std::vector<std::string> hosts;  // in the order they first appear
  std::vector<ProcessSpec> processes;

  // The processes `host` runs, in start order.
  std::vector<ProcessSpec> ProcessesOn(const std::string& host) const;
};

Layout LoadLayout(const std::string& file);
Layout ParseLayout(const std::string& text, const std::string& name);

// Which of the layout's hosts this launcher runs: `wanted` if given (it must be one of them);
// else the only host; else the one named like this machine. Throws core::UsageError listing the
// hosts when none fits.
std::string ChooseHost(const Layout& layout, const std::string& wanted,
                       const std::string& machine_name);

// Replaces ${NAME} in `text` by variables[NAME]; an unknown name throws std::invalid_argument.
std::string Expand(const std::string& text,
                   const std::vector<std::pair<std::string, std::string>>& variables);

const char* RestartName(Restart restart);

}  // namespace sirupp::launch
