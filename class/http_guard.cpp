#include "class/http_guard.hpp"

#include <fcntl.h>
#include <netdb.h>
#include <openssl/err.h>
#include <openssl/ssl.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <condition_variable>
#include <cstring>
#include <deque>
#include <stdexcept>
#include <thread>
#include <utility>
#include <vector>

#include "core/printable.hpp"

namespace sirupp::classroom {

using Clock = std::chrono::steady_clock;

namespace {

// The most of one request's request line and headers kept as sent (more: 400).
constexpr size_t kMaxRawHeaderBytes = 64 * 1024;
// How often a connection waiting between requests looks whether the server stops.
constexpr int kIdleSliceMs = 100;

// A thread per connection, made when none is free, up to `max`; the rest wait in order. Threads
// stay until the server stops (the most ever needed at once is what stays).
class ConnectionPool : public httplib::TaskQueue {
 public:
  explicit ConnectionPool(size_t max) : max_(std::max<size_t>(1, max)) {}
  ~ConnectionPool() override { shutdown(); }
  ConnectionPool(const ConnectionPool&) = delete;
  ConnectionPool& operator=(const ConnectionPool&) = delete;

  void enqueue(std::function<void()> fn) override {
    const std::lock_guard<std::mutex> lock(mutex_);
    jobs_.push_back(std::move(fn));
    if (jobs_.size() > idle_ && threads_.size() < max_) {
      threads_.emplace_back([this] { Work(); });
    } else {
      wake_.notify_one();
    }
  }

  void shutdown() override {
    std::vector<std::thread> threads;
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      stopping_ = true;
      threads.swap(threads_);
    }
    wake_.notify_all();
    for (std::thread& thread : threads) {
      if (thread.joinable()) thread.join();
    }
  }

 private:
  void Work() {
    std::unique_lock<std::mutex> lock(mutex_);
    while (true) {
      ++idle_;
      wake_.wait(lock, [this] { return stopping_ || !jobs_.empty(); });
      --idle_;
      if (jobs_.empty()) return;  // stopping, and nothing left to serve
      std::function<void()> job = std::move(jobs_.front());
      jobs_.pop_front();
      lock.unlock();
      job();
      lock.lock();
    }
  }

  const size_t max_;
  std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<std::function<void()>> jobs_;
  std::vector<std::thread> threads_;
  size_t idle_ = 0;
  bool stopping_ = false;
};

int MillisecondsUntil(Clock::time_point deadline) {
  const auto left =
      std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
  return static_cast<int>(std::clamp<long long>(left, 0, 24LL * 3600 * 1000));
}

// poll() for `events` on `fd` up to `ms`; true when ready (or the peer is gone: the next call
// says so).
bool WaitFor(int fd, short events, int ms) {
  pollfd p{fd, events, 0};
  int n = 0;
  do {
    n = ::poll(&p, 1, ms);
  } while (n < 0 && errno == EINTR);
  return n > 0;
}

void Address(const sockaddr_storage& addr, socklen_t len, std::string& ip, int& port) {
  char host[NI_MAXHOST] = "";
  char serv[NI_MAXSERV] = "";
  if (::getnameinfo(reinterpret_cast<const sockaddr*>(&addr), len, host, sizeof host, serv,
                    sizeof serv, NI_NUMERICHOST | NI_NUMERICSERV) == 0) {
    ip = host;
    port = std::atoi(serv);
  }
}

// "::ffff:10.0.0.1" and "10.0.0.1" are one address for the caps.
std::string Normalized(const std::string& ip) {
  const std::string mapped = "::ffff:";
  if (ip.rfind(mapped, 0) == 0 && ip.find('.') != std::string::npos) {
    return ip.substr(mapped.size());
  }
  return ip;
}

std::string Trim(const std::string& text) {
  const size_t begin = text.find_first_not_of(" \t");
  if (begin == std::string::npos) return "";
  return text.substr(begin, text.find_last_not_of(" \t") - begin + 1);
}

std::string ErrorJson(const std::string& message) {
  std::string out = "{\"error\": \"";
  for (const char c : message) {
    if (c == '"' || c == '\\') out += '\\';
    out += (c >= ' ' && c < 127) ? c : '?';
  }
  return out + "\"}";
}

}  // namespace

struct GuardedServer::TlsContext {
  SSL_CTX* ctx = nullptr;
  ~TlsContext() {
    if (ctx != nullptr) SSL_CTX_free(ctx);
  }
};

struct GuardedServer::Connection {
  int fd = -1;
  SSL* ssl = nullptr;
  std::string peer_ip;
  int peer_port = 0;
  std::string local_ip;
  int local_port = 0;
  std::string address;  // peer_ip, IPv4-mapped as IPv4
  // Under the server's mutex_:
  bool idle = false;     // waiting between requests
  bool evicted = false;  // closed to make room for a new connection of its address
  // This connection's thread only:
  Clock::time_point deadline{};  // of the request being read
  bool recording = false;        // keeping the request's head as sent
  std::string raw;
  std::string buffer;  // plain sockets: read ahead
  size_t buffered_from = 0;
  std::string vouched;  // the front's client this request counts against
  bool close_after = false;
};

namespace {

thread_local GuardedServer::Connection* t_connection = nullptr;

// httplib's view of one connection: reads bounded by the request's deadline, its head kept.
class GuardedStream : public httplib::Stream {
 public:
  GuardedStream(GuardedServer::Connection& conn, time_t write_timeout_s)
      : conn_(conn), write_timeout_ms_(static_cast<int>(write_timeout_s * 1000)) {}

  bool is_readable() const override {
    if (conn_.ssl != nullptr && SSL_pending(conn_.ssl) > 0) return true;
    if (conn_.buffered_from < conn_.buffer.size()) return true;
    return WaitFor(conn_.fd, POLLIN, MillisecondsUntil(conn_.deadline));
  }
  bool is_writable() const override { return WaitFor(conn_.fd, POLLOUT, write_timeout_ms_); }

  ssize_t read(char* ptr, size_t size) override {
    const ssize_t n = conn_.ssl != nullptr ? ReadTls(ptr, size) : ReadPlain(ptr, size);
    if (n > 0 && conn_.recording) {
      if (conn_.raw.size() + static_cast<size_t>(n) > kMaxRawHeaderBytes) return -1;
      conn_.raw.append(ptr, static_cast<size_t>(n));
    }
    return n;
  }

  ssize_t write(const char* ptr, size_t size) override {
    while (true) {
      if (conn_.ssl != nullptr) {
        const int n = SSL_write(conn_.ssl, ptr, static_cast<int>(std::min<size_t>(size, 1 << 20)));
        if (n > 0) return n;
        const int error = SSL_get_error(conn_.ssl, n);
        if (error == SSL_ERROR_WANT_WRITE) {
          if (!WaitFor(conn_.fd, POLLOUT, write_timeout_ms_)) return -1;
        } else if (error == SSL_ERROR_WANT_READ) {
          if (!WaitFor(conn_.fd, POLLIN, write_timeout_ms_)) return -1;
        } else {
          return -1;
        }
        continue;
      }
      const ssize_t n = ::send(conn_.fd, ptr, size, MSG_NOSIGNAL);
      if (n >= 0) return n;
      if (errno == EINTR) continue;
      if (errno != EAGAIN && errno != EWOULDBLOCK) return -1;
      if (!WaitFor(conn_.fd, POLLOUT, write_timeout_ms_)) return -1;
    }
  }

  void get_remote_ip_and_port(std::string& ip, int& port) const override {
    ip = conn_.peer_ip;
    port = conn_.peer_port;
  }
  void get_local_ip_and_port(std::string& ip, int& port) const override {
    ip = conn_.local_ip;
    port = conn_.local_port;
  }
  socket_t socket() const override { return conn_.fd; }

 private:
  ssize_t ReadPlain(char* ptr, size_t size) {
    if (conn_.buffered_from >= conn_.buffer.size()) {
      conn_.buffer.resize(4096);
      conn_.buffered_from = 0;
      while (true) {
        const ssize_t n = ::recv(conn_.fd, conn_.buffer.data(), conn_.buffer.size(), 0);
        if (n >= 0) {
          conn_.buffer.resize(static_cast<size_t>(n));
          if (n == 0) return 0;
          break;
        }
        if (errno == EINTR) continue;
        if (errno != EAGAIN && errno != EWOULDBLOCK) {
          conn_.buffer.clear();
          return -1;
        }
        const int ms = MillisecondsUntil(conn_.deadline);
        if (ms <= 0 || !WaitFor(conn_.fd, POLLIN, ms)) {
          conn_.buffer.clear();
          return -1;  // the request's deadline passed
        }
      }
    }
    const size_t n = std::min(size, conn_.buffer.size() - conn_.buffered_from);
    std::memcpy(ptr, conn_.buffer.data() + conn_.buffered_from, n);
    conn_.buffered_from += n;
    return static_cast<ssize_t>(n);
  }

  ssize_t ReadTls(char* ptr, size_t size) {
    while (true) {
      const int n = SSL_read(conn_.ssl, ptr, static_cast<int>(std::min<size_t>(size, 1 << 20)));
      if (n > 0) return n;
      const int error = SSL_get_error(conn_.ssl, n);
      if (error == SSL_ERROR_ZERO_RETURN) return 0;
      const int ms = MillisecondsUntil(conn_.deadline);
      if (error == SSL_ERROR_WANT_READ) {
        if (ms <= 0 || !WaitFor(conn_.fd, POLLIN, ms)) return -1;
      } else if (error == SSL_ERROR_WANT_WRITE) {
        if (ms <= 0 || !WaitFor(conn_.fd, POLLOUT, ms)) return -1;
      } else {
        return -1;
      }
    }
  }

  GuardedServer::Connection& conn_;
  int write_timeout_ms_;
};

// The header lines of a request's head as sent (the request line skipped).
httplib::Headers RawHeaders(const std::string& head) {
  httplib::Headers headers;
  size_t at = head.find('\n');
  while (at != std::string::npos && at + 1 < head.size()) {
    const size_t end = head.find('\n', at + 1);
    std::string line = head.substr(at + 1, end == std::string::npos ? end : end - at - 1);
    at = end;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty()) break;
    const size_t colon = line.find(':');
    if (colon == std::string::npos) continue;
    headers.emplace(line.substr(0, colon), Trim(line.substr(colon + 1)));
  }
  return headers;
}

}  // namespace

GuardedServer::GuardedServer(HttpLimits limits, const std::string& tls_cert,
                             const std::string& tls_key, std::string front_address)
    : limits_(limits), front_address_(Normalized(std::move(front_address))) {
  if (!tls_cert.empty()) {
    tls_ = std::make_unique<TlsContext>();
    tls_->ctx = SSL_CTX_new(TLS_server_method());
    if (tls_->ctx == nullptr || SSL_CTX_set_min_proto_version(tls_->ctx, TLS1_2_VERSION) != 1 ||
        SSL_CTX_use_certificate_chain_file(tls_->ctx, tls_cert.c_str()) != 1 ||
        SSL_CTX_use_PrivateKey_file(tls_->ctx, tls_key.c_str(), SSL_FILETYPE_PEM) != 1 ||
        SSL_CTX_check_private_key(tls_->ctx) != 1) {
      ERR_clear_error();
      throw std::runtime_error("cannot use the certificate " + tls_cert + " with key " + tls_key +
                               " (unreadable, or not a matching PEM pair)");
    }
    SSL_CTX_set_mode(tls_->ctx,
                     SSL_MODE_ENABLE_PARTIAL_WRITE | SSL_MODE_ACCEPT_MOVING_WRITE_BUFFER);
  }
  const auto threads = static_cast<size_t>(std::max(1, limits_.max_connections));
  new_task_queue = [threads] { return new ConnectionPool(threads); };
  set_read_timeout(std::chrono::milliseconds(static_cast<int>(limits_.request_timeout_s * 1000)));
  set_keep_alive_timeout(static_cast<time_t>(std::max(1.0, limits_.keep_alive_s)));
  set_pre_routing_handler(
      [this](const httplib::Request& req, httplib::Response& res) { return BeforeBody(req, res); });
}

GuardedServer::~GuardedServer() = default;

void GuardedServer::WidenBacklog(int backlog) {
  const socket_t sock = svr_sock_;
  if (sock != INVALID_SOCKET) ::listen(sock, backlog);  // a listening socket takes a new length
}

void GuardedServer::SetClientOf(std::function<std::string(const httplib::Request&)> client_of) {
  client_of_ = std::move(client_of);
}

bool GuardedServer::Admit(Connection& conn) {
  const bool front = !front_address_.empty() && conn.address == front_address_;
  const size_t cap = static_cast<size_t>(
      std::max(1, front ? limits_.max_connections / 2 : limits_.connections_per_address));
  const std::lock_guard<std::mutex> lock(mutex_);
  const auto [begin, end] = open_.equal_range(conn.address);
  size_t count = 0;
  for (auto it = begin; it != end; ++it) {
    if (!it->second->evicted) ++count;
  }
  if (count >= cap) {
    // An idle keep-alive connection of the same address makes room; else refused.
    auto idle = std::find_if(
        begin, end, [](const auto& entry) { return entry.second->idle && !entry.second->evicted; });
    if (idle == end) return false;
    idle->second->evicted = true;
    ::shutdown(idle->second->fd, SHUT_RDWR);
  }
  open_.emplace(conn.address, &conn);
  return true;
}

void GuardedServer::Leave(Connection& conn) {
  const std::lock_guard<std::mutex> lock(mutex_);
  const auto [begin, end] = open_.equal_range(conn.address);
  for (auto it = begin; it != end; ++it) {
    if (it->second == &conn) {
      open_.erase(it);
      break;
    }
  }
}

httplib::Server::HandlerResponse GuardedServer::BeforeBody(const httplib::Request& req,
                                                           httplib::Response& res) {
  Connection* conn = t_connection;
  if (conn == nullptr || !client_of_) return HandlerResponse::Unhandled;
  const std::string client = client_of_(req);
  if (client.empty()) return HandlerResponse::Unhandled;
  const std::string key = Normalized(client);
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    int& count = requests_[key];
    if (count < limits_.connections_per_address) {
      ++count;
      conn->vouched = key;
      return HandlerResponse::Unhandled;
    }
    if (count == 0) requests_.erase(key);
  }
  conn->close_after = true;  // its body, if any, is not read
  res.status = 429;
  res.set_header("Retry-After", "5");
  res.set_header("Connection", "close");
  res.set_content(ErrorJson("too many requests at once from " + core::Printable(client, 60) +
                            " (server.connections_per_address: " +
                            std::to_string(limits_.connections_per_address) + ")"),
                  "application/json");
  return HandlerResponse::Handled;
}

bool GuardedServer::process_and_close_socket(socket_t sock) {
  Connection conn;
  conn.fd = sock;
  {
    sockaddr_storage addr{};
    socklen_t len = sizeof addr;
    if (::getpeername(sock, reinterpret_cast<sockaddr*>(&addr), &len) == 0) {
      Address(addr, len, conn.peer_ip, conn.peer_port);
    }
    len = sizeof addr;
    if (::getsockname(sock, reinterpret_cast<sockaddr*>(&addr), &len) == 0) {
      Address(addr, len, conn.local_ip, conn.local_port);
    }
  }
  conn.address = Normalized(conn.peer_ip);
  const int flags = ::fcntl(sock, F_GETFL, 0);
  if (flags >= 0) ::fcntl(sock, F_SETFL, flags | O_NONBLOCK);

  const auto close_socket = [&conn] {
    if (conn.ssl != nullptr) {
      SSL_shutdown(conn.ssl);
      SSL_free(conn.ssl);
      conn.ssl = nullptr;
    }
    ::shutdown(conn.fd, SHUT_RDWR);
    ::close(conn.fd);
  };

  if (!Admit(conn)) {
    if (!tls_) {
      const std::string body = ErrorJson(
          "too many connections from " + conn.address + " (server.connections_per_address: " +
          std::to_string(limits_.connections_per_address) + "); close some and retry");
      const std::string answer =
          "HTTP/1.1 429 Too Many Requests\r\nConnection: close\r\n"
          "Retry-After: 5\r\nContent-Type: application/json\r\n"
          "Content-Length: " +
          std::to_string(body.size()) + "\r\n\r\n" + body;
      [[maybe_unused]] const ssize_t sent =
          ::send(sock, answer.data(), answer.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
      // What the client sent so far is read away, so that the close is a FIN after the answer
      // (unread data would make it a reset that may lose the answer).
      char sink[4096];
      while (::recv(sock, sink, sizeof sink, MSG_DONTWAIT) > 0) {
      }
    }
    close_socket();
    return false;
  }

  bool ok = true;
  if (tls_) {
    conn.ssl = SSL_new(tls_->ctx);
    ok = conn.ssl != nullptr && SSL_set_fd(conn.ssl, sock) == 1;
    const auto deadline = Clock::now() + std::chrono::milliseconds(
                                             static_cast<int>(limits_.request_timeout_s * 1000));
    while (ok) {
      const int n = SSL_accept(conn.ssl);
      if (n == 1) break;
      const int error = SSL_get_error(conn.ssl, n);
      const int ms = MillisecondsUntil(deadline);
      if (error == SSL_ERROR_WANT_READ && ms > 0 && WaitFor(sock, POLLIN, ms)) continue;
      if (error == SSL_ERROR_WANT_WRITE && ms > 0 && WaitFor(sock, POLLOUT, ms)) continue;
      ok = false;
    }
    ERR_clear_error();
  }

  t_connection = &conn;
  GuardedStream stream(conn, write_timeout_sec_);
  const auto keep_alive = std::chrono::milliseconds(static_cast<int>(limits_.keep_alive_s * 1000));
  for (size_t count = keep_alive_max_count_; ok && count > 0; --count) {
    // Between requests: idle until a byte comes, keep_alive_s passes, or the server stops.
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      conn.idle = true;
    }
    const auto idle_until = Clock::now() + keep_alive;
    bool ready = conn.buffered_from < conn.buffer.size() ||
                 (conn.ssl != nullptr && SSL_pending(conn.ssl) > 0);
    while (!ready && svr_sock_ != INVALID_SOCKET) {
      const int ms = std::min(kIdleSliceMs, MillisecondsUntil(idle_until));
      if (ms <= 0) break;
      ready = WaitFor(sock, POLLIN, ms);
    }
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      conn.idle = false;
      if (conn.evicted) ready = false;
    }
    if (!ready || svr_sock_ == INVALID_SOCKET) break;
    conn.deadline = Clock::now() +
                    std::chrono::milliseconds(static_cast<int>(limits_.request_timeout_s * 1000));
    conn.raw.clear();
    conn.recording = true;
    conn.close_after = false;
    bool closed = false;
    ok = process_request(stream, count == 1, closed, [&conn](httplib::Request& req) {
      // The head is in (httplib reads it a byte at a time, so nothing of the body yet): the
      // values as sent replace httplib's decoded ones.
      conn.recording = false;
      httplib::Headers headers = RawHeaders(conn.raw);
      for (const char* own : {"REMOTE_ADDR", "REMOTE_PORT", "LOCAL_ADDR", "LOCAL_PORT"}) {
        headers.erase(own);
      }
      headers.emplace("REMOTE_ADDR", req.remote_addr);
      headers.emplace("REMOTE_PORT", std::to_string(req.remote_port));
      headers.emplace("LOCAL_ADDR", req.local_addr);
      headers.emplace("LOCAL_PORT", std::to_string(req.local_port));
      req.headers = std::move(headers);
    });
    conn.recording = false;
    if (!conn.vouched.empty()) {
      const std::lock_guard<std::mutex> lock(mutex_);
      const auto found = requests_.find(conn.vouched);
      if (found != requests_.end() && --found->second <= 0) requests_.erase(found);
      conn.vouched.clear();
    }
    if (closed || conn.close_after) break;
  }
  t_connection = nullptr;
  Leave(conn);
  close_socket();
  return ok;
}

}  // namespace sirupp::classroom
