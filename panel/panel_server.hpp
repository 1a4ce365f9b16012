#pragma once
// cpp-httplib around PanelApi: the page's files (panel/web), the JavaScript libraries from the
// Debian packages (/usr/share/javascript: three.js, dygraphs), the JSON API, and the live state as
// Server-Sent Events (/api/events?hz=N), sampled from the hub at the page's rate.

#include <memory>
#include <string>

#include "panel/panel_api.hpp"
#include "panel/panel_hub.hpp"

namespace sirupp::panel {

struct ServerOptions {
  std::string listen = "127.0.0.1";
  int port = 8765;                               // 0 = any free port
  std::string web_dir;                           // the page's files
  std::string js_dir = "/usr/share/javascript";  // Debian's libjs-* packages
  double max_rate_hz = 60;                       // the fastest a page may ask for
  int threads = 24;                              // each open event stream holds one
};

class PanelServer {
 public:
  PanelServer(PanelHub& hub, PanelApi& api, ServerOptions options);
  ~PanelServer();
  PanelServer(const PanelServer&) = delete;
  PanelServer& operator=(const PanelServer&) = delete;

  // Binds (throws std::runtime_error naming the address when it cannot); returns the port.
  int Bind();
  // Serves until Stop() (blocking).
  void Serve();
  void Stop();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// True for 127.0.0.0/8, ::1 and "localhost".
bool IsLoopback(const std::string& address);

}  // namespace sirupp::panel
