#include "panel/panel_server.hpp"

#include <chrono>
#include <cmath>
#include <stdexcept>
#include <thread>

#include "panel/http_glue.hpp"

namespace sirupp::panel {
namespace {

using Clock = std::chrono::steady_clock;

double WallMs() {
  return static_cast<double>(std::chrono::duration_cast<std::chrono::microseconds>(
                                 std::chrono::system_clock::now().time_since_epoch())
                                 .count()) /
         1000.0;
}

}  // namespace

Request ToRequest(const httplib::Request& req) {
  Request out;
  out.method = req.method;
  out.path = req.path;
  for (const auto& [key, value] : req.params) out.query.emplace(key, value);
  out.body = req.body;
  out.remote_addr = req.remote_addr;
  out.client = req.get_header_value("X-Sirupp-Client");
  out.token = req.get_header_value("X-Sirupp-Token");
  return out;
}

void Send(const Response& from, httplib::Response& res) {
  res.status = from.status;
  res.set_header("Cache-Control", "no-store");
  res.set_content(from.body, from.content_type.c_str());
}

void StreamState(PanelHub& hub, PanelApi& api, double max_rate_hz, const httplib::Request& req,
                 httplib::Response& res, std::shared_ptr<void> keep,
                 std::function<void()> on_frame) {
  double hz = max_rate_hz;
  if (req.has_param("hz")) {
    char* end = nullptr;
    const std::string text = req.get_param_value("hz");
    const double asked = std::strtod(text.c_str(), &end);
    if (end == text.c_str() || *end != '\0' || !(asked > 0)) {
      Send(ErrorResponse(400, "hz: a number > 0 (frames per second)"), res);
      return;
    }
    hz = std::min(asked, max_rate_hz);
  }
  const auto period =
      std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / hz));
  auto generation = std::make_shared<int64_t>(-1);
  auto next = std::make_shared<Clock::time_point>(Clock::now());
  res.set_header("Cache-Control", "no-store");
  res.set_header("X-Accel-Buffering", "no");
  res.set_chunked_content_provider(
      "text/event-stream",
      [&hub, &api, period, generation, next, keep, on_frame](size_t, httplib::DataSink& sink) {
        std::this_thread::sleep_until(*next);
        *next = std::max(*next + period, Clock::now());
        const int64_t now_generation = hub.WaitForState(*generation, std::chrono::seconds(1));
        if (hub.stopping()) {
          sink.done();
          return true;
        }
        std::string frame;
        if (now_generation == *generation) {
          frame = ": idle\n\n";  // keeps proxies and the browser's connection alive
        } else {
          *generation = now_generation;
          Json state = hub.StateJson();
          state["lock"] = api.LockHolder();
          state["sent_ms"] = WallMs();
          frame = "data: " + state.dump(-1, ' ', false, Json::error_handler_t::replace) + "\n\n";
        }
        if (on_frame) on_frame();
        return sink.write(frame.data(), frame.size());
      });
}

int BindServer(httplib::Server& server, const std::string& listen, int port) {
  int bound = -1;
  if (port == 0) {
    bound = server.bind_to_any_port(listen.c_str());
  } else if (server.bind_to_port(listen.c_str(), port)) {
    bound = port;
  }
  if (bound <= 0) {
    throw std::runtime_error("cannot listen on " + listen + ":" + std::to_string(port) +
                             " (address not on this computer, or the port is in use)");
  }
  return bound;
}

void AnswerExceptionsWith500(httplib::Server& server) {
  server.set_exception_handler(
      [](const httplib::Request&, httplib::Response& res, std::exception_ptr error) {
        std::string what = "internal error";
        try {
          if (error) std::rethrow_exception(error);
        } catch (const std::exception& e) {
          what = e.what();
        } catch (...) {
        }
        Send(ErrorResponse(500, what), res);
      });
}

bool ListenGate::Listen(httplib::Server& server) {
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    if (stopping_) return false;
    listening_ = true;
  }
  server.listen_after_bind();
  const std::lock_guard<std::mutex> lock(mutex_);
  listening_ = false;
  return true;
}

void ListenGate::Stop(httplib::Server& server) {
  bool stopped = false;
  for (;;) {
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      stopping_ = true;
      if (!listening_) return;
    }
    // Listening, or about to: stop the loop once it says it runs (stop() closes its socket).
    if (!stopped && server.is_running()) {
      server.stop();
      stopped = true;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
}

bool IsLoopback(const std::string& address) {
  return address == "localhost" || address == "::1" || address.rfind("127.", 0) == 0;
}

struct PanelServer::Impl {
  PanelHub& hub;
  PanelApi& api;
  ServerOptions options;
  httplib::Server server;
  ListenGate gate;
  int port = 0;

  Impl(PanelHub& h, PanelApi& a, ServerOptions o) : hub(h), api(a), options(std::move(o)) {}

  void Routes() {
    const int threads = options.threads;
    server.new_task_queue = [threads] {
      return new httplib::ThreadPool(static_cast<size_t>(threads));
    };
    server.set_payload_max_length(1024 * 1024);
    server.set_keep_alive_max_count(1000);
    server.set_default_headers({{"X-Content-Type-Options", "nosniff"}});
    if (!server.set_mount_point("/", options.web_dir)) {
      throw std::runtime_error("the page's folder " + options.web_dir + " does not exist");
    }
    // Only the two libraries the page uses, not all of /usr/share/javascript.
    server.set_mount_point("/js/three", options.js_dir + "/three");
    server.set_mount_point("/js/dygraphs", options.js_dir + "/dygraphs");
    server.Get("/api/events", [this](const httplib::Request& req, httplib::Response& res) {
      StreamState(hub, api, options.max_rate_hz, req, res);
    });
    const auto api_handler = [this](const httplib::Request& req, httplib::Response& res) {
      Send(api.Handle(ToRequest(req)), res);
    };
    server.Get(R"(/api/.*)", api_handler);
    server.Post(R"(/api/.*)", api_handler);
    server.Put(R"(/api/.*)", api_handler);
    server.Delete(R"(/api/.*)", api_handler);
    AnswerExceptionsWith500(server);
  }
};

PanelServer::PanelServer(PanelHub& hub, PanelApi& api, ServerOptions options)
    : impl_(std::make_unique<Impl>(hub, api, std::move(options))) {
  impl_->Routes();
}

PanelServer::~PanelServer() { Stop(); }

int PanelServer::Bind() {
  impl_->port = BindServer(impl_->server, impl_->options.listen, impl_->options.port);
  return impl_->port;
}

void PanelServer::Serve() { impl_->gate.Listen(impl_->server); }

void PanelServer::Stop() {
  if (impl_) impl_->gate.Stop(impl_->server);
}

}  // namespace sirupp::panel
