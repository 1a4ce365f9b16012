#pragma once
// The class server's HTTP connections, held against slow and crowding clients and read exactly as
// they were sent. cpp-httplib (Debian's 0.11.4) gives every connection one thread of a fixed pool
// for as long as it lasts, with no deadline for a request's headers, and it percent-decodes every
// header value as it parses it ("%61lice" reads "alice"). GuardedServer is an httplib::Server
// that keeps httplib's parsing and routing but owns each connection itself:
//
//   - a deadline for each request's headers and body together (server.request_timeout_s), from
//     its first byte; a request not in by then ends the connection;
//   - an idle keep-alive connection closed after server.keep_alive_s, and at once when its
//     address needs the place (a new connection from an address at its cap takes the place of
//     one of its idle ones);
//   - at most server.connections_per_address connections from one TCP address (more: 429 and
//     closed at once, without a thread kept), and the same for the requests in progress of one
//     client the front vouches for (`client_of`, checked before any body is read); connections
//     from the front's own address (server.trusted_proxy) count against max_connections / 2;
//   - a thread per connection up to server.max_connections, made when needed;
//   - the request's headers as sent: the decoded values httplib made are replaced with the raw
//     text of each header line (leading and trailing blanks removed), so a name, token or secret
//     is compared as it came;
//   - HTTPS with OpenSSL when a certificate is given (the same deadlines for the handshake).
//
// What it reads: the sockets httplib accepts. What it writes: the answers of httplib's handlers,
// and its own 429 / 431 refusals (JSON {"error": ...}).

#include <chrono>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>

#include "class/class_config.hpp"  // HttpLimits
#include "panel/httplib_include.hpp"

namespace sirupp::classroom {

class GuardedServer : public httplib::Server {
 public:
  // `tls_cert` / `tls_key`: PEM files for HTTPS; both empty for HTTP. Throws std::runtime_error
  // naming them when they do not make a matching pair. `front_address`: the front's address
  // ("" without a front).
  GuardedServer(HttpLimits limits, const std::string& tls_cert, const std::string& tls_key,
                std::string front_address);
  ~GuardedServer() override;
  GuardedServer(const GuardedServer&) = delete;
  GuardedServer& operator=(const GuardedServer&) = delete;

  // After binding: the listening socket's queue of connections not yet accepted made `backlog`
  // long (httplib's is 5, so a burst of connections would wait for SYN retransmits, 1 s and 3 s).
  void WidenBacklog(int backlog);

  // The client a request is from when it is not its TCP peer: the address the front vouches for
  // (with its secret), else "" (the peer counts). Called before the body is read.
  void SetClientOf(std::function<std::string(const httplib::Request&)> client_of);

  struct Connection;  // http_guard.cpp

 private:
  bool process_and_close_socket(socket_t sock) override;
  httplib::Server::HandlerResponse BeforeBody(const httplib::Request& req, httplib::Response& res);
  // Counts `conn` against its address; false when the address is at its cap and no idle
  // connection of it could make room.
  bool Admit(Connection& conn);
  void Leave(Connection& conn);

  HttpLimits limits_;
  std::string front_address_;
  struct TlsContext;
  std::unique_ptr<TlsContext> tls_;
  std::function<std::string(const httplib::Request&)> client_of_;
  mutable std::mutex mutex_;
  std::multimap<std::string, Connection*> open_;  // by address
  std::map<std::string, int> requests_;           // requests in progress per vouched client
};

}  // namespace sirupp::classroom
