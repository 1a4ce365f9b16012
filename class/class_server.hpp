#pragma once
// The class server behind `sirupp class serve`: one HTTP server in front of a private rig per
// student. It owns the tokens, the routes and the teacher's view; the rigs' lifetimes (started on a
// student's first visit, stopped after the idle timeout, at most max_rigs at once, local processes
// or cluster jobs) are the rig pool's (class/rig_pool.hpp).
//
//   /s/NAME/...    the panel's page and API (panel/web, panel::PanelApi) for NAME's rig; NAME's
//                  token opens it, the teacher's token opens it read-only, anything else is 403
//   /teacher/...   every rig on one page, one event stream for all; stop, restart, e-stop all
//
// A token comes as ?token= (then kept in an HttpOnly cookie scoped to the path, and the address
// redirected without it), the X-Sirupp-Token header, or that cookie. Repeated bad tokens from one
// address are refused for a growing time (429). Every bad request gets a 4xx with a one-line
// message; a handler that throws is a 500, never a crash.

#include <iosfwd>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "class/class_config.hpp"

namespace sirupp::classroom {

struct ServeOptions {
  std::string bin_dir;        // sirupp-sim, sirupp-control, sirupp-logger
  std::string panel_web_dir;  // panel/web
  std::string class_web_dir;  // class/web
  std::string config_dir;     // the config/ copied into a new student's folder
  std::string js_dir = "/usr/share/javascript";
  std::ostream* log = nullptr;  // one line per start, stop, refusal
  double stream_hz = 30;        // the fastest a student's page may ask for (panel: 60)
};

// The class's files in its data folder.
std::string TokensFile(const ClassConfig& config);   // DATA/tokens.json (hashes)
std::string HandoutFile(const ClassConfig& config);  // DATA/tokens.csv (addresses, for the teacher)
std::string StudentFolder(const ClassConfig& config, const std::string& name);  // rig_pool.cpp
std::string TurnsLogFile(const ClassConfig& config);  // DATA/turns.jsonl (the real arm's turns)

// The address that opens `name`'s page (or the teacher's) with `token`.
std::string AddressWithToken(const ClassConfig& config, int port, const std::string& name,
                             const std::string& token);

// Issues tokens to the teacher and every student without one; appends their addresses to the
// handout. Returns the rows issued (name, address).
std::vector<std::pair<std::string, std::string>> IssueMissingTokens(const ClassConfig& config,
                                                                    int port);
// A new token for `name` (a student or "teacher"), replacing the old one; appended to the
// handout. Throws core::UsageError for a name not in the class.
std::pair<std::string, std::string> ReissueToken(const ClassConfig& config, int port,
                                                 const std::string& name);

class ClassServer {
 public:
  ClassServer(ClassConfig config, ServeOptions options);
  ~ClassServer();
  ClassServer(const ClassServer&) = delete;
  ClassServer& operator=(const ClassServer&) = delete;

  // Binds the address of the class file (throws std::runtime_error naming it); returns the port.
  int Bind();
  // Serves until Stop() (blocking); a monitor thread stops idle rigs and reaps ended ones.
  void Serve();
  // Stops every rig, then the server. Safe to call from another thread and twice.
  void Stop();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace sirupp::classroom
