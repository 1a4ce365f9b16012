#pragma once
// cpp-httplib around PanelApi, shared by sirupp-panel (panel_server.cpp) and every server that
// hosts a panel per rig (the class server, class/): a request as the API sees it, its answer, and
// the live state as Server-Sent Events.

#include <functional>
#include <memory>
#include <mutex>

// The panel's headers (and so Eigen) first: httplib.h brings <resolv.h>, whose `_res` macro breaks
// Eigen headers included after it.
#include "panel/panel_api.hpp"
#include "panel/panel_hub.hpp"
// clang-format off
#include "panel/httplib_include.hpp"
// clang-format on

namespace sirupp::panel {

Request ToRequest(const httplib::Request& req);
void Send(const Response& from, httplib::Response& res);

// Makes `res` the live state's event stream: one "data:" frame (StateJson, the lock holder and the
// send time) per change of the hub's state, at most min(hz query parameter, max_rate_hz) per
// second, ": idle" comments while nothing changes; ends when the hub stops. A bad hz is a 400.
// `keep` is held while the stream is open (the owner of hub and api); `on_frame` is called for
// every frame written.
void StreamState(PanelHub& hub, PanelApi& api, double max_rate_hz, const httplib::Request& req,
                 httplib::Response& res, std::shared_ptr<void> keep = nullptr,
                 std::function<void()> on_frame = {});

// Binds `server` to listen:port (port 0: any free port) and returns the port; throws
// std::runtime_error naming the address when it cannot.
int BindServer(httplib::Server& server, const std::string& listen, int port);
// A handler that throws is answered 500 {"error": what}, never a crash.
void AnswerExceptionsWith500(httplib::Server& server);

// Serves a bound server on the caller's thread until Stop() from another. httplib's own stop()
// does nothing before the listen loop has marked itself running, so a Stop() that comes first
// (a test that ends at once) would leave Listen() serving forever; with the gate, Stop() before
// Listen() makes Listen() return at once, and Stop() during the loop's start waits for it.
class ListenGate {
 public:
  // False when Stop() came first (nothing was served).
  bool Listen(httplib::Server& server);
  void Stop(httplib::Server& server);

 private:
  std::mutex mutex_;
  bool stopping_ = false;
  bool listening_ = false;
};

}  // namespace sirupp::panel
