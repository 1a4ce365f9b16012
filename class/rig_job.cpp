#include "class/rig_job.hpp"

#include <arpa/inet.h>
#include <netdb.h>
#include <openssl/crypto.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <thread>
#include <vector>

#include "class/bus_relay.hpp"
#include "grade/port_lease.hpp"
#include "panel/http_glue.hpp"
#include "proc/udpm_listen.hpp"

namespace sirupp::classroom {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using Json = nlohmann::json;

constexpr double kQuietListenS = 1.2;  // every SIRUPP process sends a heartbeat each second

// The host part of http(s)://HOST[:PORT][/...] ("[::1]" without the brackets).
std::string UrlHost(const std::string& url) {
  const size_t scheme = url.find("://");
  std::string rest = scheme == std::string::npos ? url : url.substr(scheme + 3);
  rest = rest.substr(0, rest.find('/'));
  if (!rest.empty() && rest[0] == '[') return rest.substr(1, rest.find(']') - 1);
  return rest.substr(0, rest.find(':'));
}

int UrlPort(const std::string& url) {
  const size_t scheme = url.find("://");
  std::string rest = scheme == std::string::npos ? url : url.substr(scheme + 3);
  rest = rest.substr(0, rest.find('/'));
  const size_t bracket = rest.find(']');
  const size_t colon = rest.find(':', bracket == std::string::npos ? 0 : bracket);
  if (colon != std::string::npos) return std::atoi(rest.c_str() + colon + 1);
  return url.rfind("https://", 0) == 0 ? 443 : 80;
}

bool SameSecret(const std::string& offered, const std::string& secret) {
  return offered.size() == secret.size() &&
         CRYPTO_memcmp(offered.data(), secret.data(), secret.size()) == 0;
}

}  // namespace

std::string RigJobEndFile(const std::string& folder, const std::string& job_id) {
  return folder + "/logs/rig-job-" + job_id + ".end";
}

std::string LocalAddressTowards(const std::string& url) {
  const std::string host = UrlHost(url);
  addrinfo hints{};
  hints.ai_socktype = SOCK_DGRAM;
  addrinfo* found = nullptr;
  const std::string port = std::to_string(UrlPort(url));
  if (::getaddrinfo(host.c_str(), port.c_str(), &hints, &found) != 0 || found == nullptr) {
    throw std::runtime_error("cannot resolve '" + host + "' (of " + url + ")");
  }
  std::string address;
  for (addrinfo* at = found; at != nullptr && address.empty(); at = at->ai_next) {
    const int fd = ::socket(at->ai_family, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    if (fd < 0) continue;
    sockaddr_storage local{};
    socklen_t size = sizeof local;
    if (::connect(fd, at->ai_addr, at->ai_addrlen) == 0 &&
        ::getsockname(fd, reinterpret_cast<sockaddr*>(&local), &size) == 0) {
      char text[INET6_ADDRSTRLEN] = {};
      const void* raw =
          local.ss_family == AF_INET
              ? static_cast<const void*>(&reinterpret_cast<sockaddr_in*>(&local)->sin_addr)
              : static_cast<const void*>(&reinterpret_cast<sockaddr_in6*>(&local)->sin6_addr);
      if (::inet_ntop(local.ss_family, raw, text, sizeof text) != nullptr) address = text;
    }
    ::close(fd);
  }
  ::freeaddrinfo(found);
  if (address.empty()) throw std::runtime_error("no route from this node to '" + host + "'");
  return address;
}

struct RigJob::Impl {
  RigJobOptions options;
  ProcessLauncher launcher;  // outlives the rig
  grade::PortLease lease;
  std::unique_ptr<Rig> rig;
  // The real arm's relay for this rig (class/bus_relay.hpp): listens on the rig's bus only while
  // the class server exchanges with it (a handover or a turn of this student's).
  std::unique_ptr<RelayTap> tap;
  std::mutex tap_mutex;  // one exchange at a time
  int bus_port = 0;      // the rig's udpm port (leased or given)
  std::unique_ptr<httplib::Server> server;
  panel::ListenGate gate;
  std::thread serving;
  std::mutex stop_mutex;
  bool stopped = false;
  Clock::time_point started = Clock::now();

  explicit Impl(RigJobOptions o) : options(std::move(o)) {}

  // A port of the range that no other rig on this node holds and where nothing talks.
  void LeaseQuietPort() {
    std::string heard;
    std::vector<grade::PortLease> busy;
    const int offset = static_cast<int>(::getpid() % options.port_count);
    for (int k = 0; k < std::min(8, options.port_count); ++k) {
      grade::PortLease candidate =
          grade::PortLease::Acquire(options.first_port, options.port_count, offset + k);
      const std::string talk = proc::HeardOnUdpm(proc::kRigGroup, candidate.port(), kQuietListenS);
      if (talk.empty()) {
        lease = std::move(candidate);
        return;
      }
      heard = talk;
      busy.push_back(std::move(candidate));
    }
    throw std::runtime_error(
        "no quiet udpm port on this node in " + std::to_string(options.first_port) + ".." +
        std::to_string(options.first_port + options.port_count - 1) + " (" + heard + ")");
  }

  bool Authorized(const httplib::Request& req, httplib::Response& res) const {
    if (SameSecret(req.get_header_value(kRigSecretHeader), options.secret)) return true;
    panel::Send(panel::ErrorResponse(403, "this rig's endpoint answers its class server only"),
                res);
    return false;
  }

  void Routes() {
    server = std::make_unique<httplib::Server>();
    server->new_task_queue = [] { return new httplib::ThreadPool(16); };
    server->set_payload_max_length(1024 * 1024);
    server->set_tcp_nodelay(true);  // the real arm's relay: an answer per exchange, at once
    const auto api = [this](const httplib::Request& req, httplib::Response& res) {
      if (!Authorized(req, res)) return;
      const std::shared_ptr<RigPanel> rig_panel = rig ? rig->panel() : nullptr;
      if (!rig_panel) {
        panel::Send(panel::ErrorResponse(503, "the rig is stopping"), res);
        return;
      }
      if (req.path == "/api/events") {
        panel::StreamState(*rig_panel->hub, *rig_panel->api, options.stream_hz, req, res,
                           rig_panel);
        return;
      }
      panel::Send(rig_panel->api->Handle(panel::ToRequest(req)), res);
    };
    server->Get(R"(/api/.*)", api);
    server->Post(R"(/api/.*)", api);
    server->Get("/rig", [this](const httplib::Request& req, httplib::Response& res) {
      if (!Authorized(req, res)) return;
      panel::Send(panel::Response{200, "application/json",
                                  Json{{"student", options.spec.student},
                                       {"job", options.job_id},
                                       {"udpm_port", lease.port()},
                                       {"lcm_url", RigUrl(lease.port())}}
                                      .dump()},
                  res);
    });
    server->Post(kRelayPath, [this](const httplib::Request& req, httplib::Response& res) {
      if (!Authorized(req, res)) return;
      const std::lock_guard<std::mutex> lock(tap_mutex);
      if (!tap) tap = std::make_unique<RelayTap>(RigUrl(bus_port));
      try {
        res.set_content(tap->Exchange(req.body), "application/octet-stream");
      } catch (const std::invalid_argument& e) {
        panel::Send(panel::ErrorResponse(400, e.what()), res);
      }
    });
    panel::AnswerExceptionsWith500(*server);
  }
};

RigJob::RigJob(RigJobOptions options) : impl_(std::make_unique<Impl>(std::move(options))) {
  if (impl_->options.secret.size() < 32) {
    throw std::invalid_argument("the rig's secret is " +
                                std::to_string(impl_->options.secret.size()) +
                                " characters; at least 32 are needed");
  }
}

RigJob::~RigJob() { Stop("the rig job ended"); }

int RigJob::udpm_port() const { return impl_->lease.port(); }

void RigJob::Start() {
  Impl& impl = *impl_;
  RigSpec spec = impl.options.spec;
  if (spec.port == 0) {
    impl.LeaseQuietPort();
    spec.port = impl.lease.port();
  }
  impl.bus_port = spec.port;
  impl.rig = std::make_unique<Rig>(spec, impl.launcher);
  impl.rig->Start();
  impl.Routes();
  host_ = impl.options.listen;
  if (host_.empty()) {
    host_ = impl.options.report_url.empty() ? "127.0.0.1"
                                            : LocalAddressTowards(impl.options.report_url);
  }
  http_port_ = panel::BindServer(*impl.server, host_, impl.options.http_port);
}

void RigJob::Serve() {
  impl_->serving = std::thread([this] { impl_->gate.Listen(*impl_->server); });
}

void RigJob::Report() {
  const RigJobOptions& options = impl_->options;
  if (options.report_url.empty()) return;
  const Json body{{"student", options.spec.student},
                  {"job", options.job_id},
                  {"host", host_},
                  {"port", http_port_},
                  {"udpm_port", udpm_port()}};
  const auto deadline = Clock::now() + std::chrono::milliseconds(
                                           static_cast<int64_t>(options.report_timeout_s * 1000));
  std::string last = "no answer";
  while (Clock::now() < deadline) {
    httplib::Client client(options.report_url);
    client.set_connection_timeout(5);
    client.set_read_timeout(10);
    const httplib::Headers headers = {{kRigSecretHeader, options.secret}};
    const auto answer = client.Post(kRigReportPath, headers, body.dump(), "application/json");
    if (answer && answer->status == 200) return;
    if (answer) {
      last = "HTTP " + std::to_string(answer->status) + ": " + answer->body.substr(0, 200);
      // A refusal (not this rig's secret, not its job any more) does not change by retrying.
      if (answer->status == 403 || answer->status == 404 || answer->status == 409) break;
    } else {
      last = httplib::to_string(answer.error());
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
  }
  throw std::runtime_error("the class server at " + options.report_url +
                           " did not take this rig's address: " + last);
}

std::string RigJob::CheckProcesses() { return impl_->rig ? impl_->rig->CheckProcesses() : ""; }

void RigJob::Stop(const std::string& why) {
  Impl& impl = *impl_;
  {
    const std::lock_guard<std::mutex> lock(impl.stop_mutex);
    if (impl.stopped) return;
    impl.stopped = true;
  }
  if (impl.rig) {
    if (const auto rig_panel = impl.rig->panel()) rig_panel->hub->Stop();  // streams end
  }
  if (impl.server) impl.gate.Stop(*impl.server);
  if (impl.serving.joinable()) impl.serving.join();
  impl.tap.reset();  // its listener off the rig's bus
  if (impl.rig) impl.rig->Stop();
  impl.lease.Release();
  const std::string folder = impl.options.spec.folder;
  if (!impl.options.job_id.empty() && fs::is_directory(folder + "/logs")) {
    const double seconds = std::chrono::duration<double>(Clock::now() - impl.started).count();
    const std::time_t now = std::time(nullptr);
    char stamp[32];
    std::strftime(stamp, sizeof stamp, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&now));
    std::ofstream out(RigJobEndFile(folder, impl.options.job_id), std::ios::trunc);
    out << why << " (rig job " << impl.options.job_id << " on " << host_ << ", at " << stamp
        << " after " << static_cast<int>(seconds) << " s)\n";
  }
}

}  // namespace sirupp::classroom
