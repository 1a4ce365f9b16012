#pragma once
// The panel's HTTP API as plain functions of a request: routes, the control lock, the token rule,
// file access limited to config/ and the results folder, and the JSON answers. Free of any HTTP
// library, so tests drive it directly over a memq:// hub (panel_server.cpp only adapts
// cpp-httplib to it). Every bad request gets a 4xx with {"error": "..."}; nothing here throws to
// the caller.
//
// Rules for a request that changes anything (POST to a command route):
//  - it carries the header X-Sirupp-Client (an id the page makes up): a plain HTML form or a
//    cross-site script cannot send it without a CORS preflight, which the panel never grants;
//  - with a token in force (--listen to a non-loopback address, or --require-token), it carries
//    X-Sirupp-Token equal to the token printed at start: else 403;
//  - it comes from the client holding the control lock: else 409 naming the holder. Engaging the
//    e-stop is allowed from any client.

#include <chrono>
#include <filesystem>
#include <map>
#include <optional>
#include <string>

#include "panel/panel_hub.hpp"
#include "panel/rig_commands.hpp"

namespace sirupp::panel {

struct Request {
  std::string method;  // "GET" or "POST"
  std::string path;    // without the query
  std::map<std::string, std::string> query;
  std::string body;
  std::string remote_addr;
  std::string client;  // X-Sirupp-Client
  std::string token;   // X-Sirupp-Token
};

struct Response {
  int status = 200;
  std::string content_type = "application/json";
  std::string body;
};

struct ApiOptions {
  std::string root;         // the tree holding config/ (the source tree or the working directory)
  std::string results_dir;  // readable besides config/; "" = none
  bool require_token = false;
  std::string token;
  // The lock is dropped when its holder sent nothing for this long (closed the page).
  std::chrono::seconds lock_idle{30};
};

class PanelApi {
 public:
  PanelApi(PanelHub& hub, ApiOptions options);

  Response Handle(const Request& request);

  // The present lock holder's name, "" when free.
  std::string LockHolder();

 private:
  struct Lock {
    std::string client;
    std::string name;
    std::chrono::steady_clock::time_point since;
    std::chrono::steady_clock::time_point seen;
  };

  Response Get(const Request& request);
  Response Post(const Request& request, const Json& body);
  Response LockJson(const std::string& client);
  Response TakeLock(const Request& request, const Json& body);
  Response ReadFile(const std::string& path);
  Response ListFiles(const std::string& which);
  Response SolveIk(const Json& body);
  Response CheckEnvironment(const Json& body);
  // Record panel: the logger's state and the runs in the results folder; a run's report.
  Response RecordJson();
  Response RunReport(const Json& body);
  Response Download(const std::string& path);
  // Model panel: a model file's editable values; an edit checked, or saved as a new file.
  Response ModelFields(const std::string& path);
  Response ModelEdit(const Json& body, bool save);
  // The canonical path of `path` when it lies under config/ (or, with results, the results
  // folder); nullopt otherwise.
  std::optional<std::filesystem::path> Allowed(const std::string& path, bool results) const;
  bool Holds(const std::string& client);
  void Seen(const std::string& client);

  PanelHub& hub_;
  ApiOptions options_;
  RigCommands commands_;
  std::mutex lock_mutex_;
  std::optional<Lock> lock_;
};

// {"error": message} with `status`.
Response ErrorResponse(int status, const std::string& message);

}  // namespace sirupp::panel
