#include "class/rig_proxy.hpp"

#include <atomic>
#include <chrono>
#include <thread>

#include "class/rig_job.hpp"

namespace sirupp::classroom {
namespace {

httplib::Client Connect(const RigEndpoint& endpoint, double timeout_s) {
  httplib::Client client(endpoint.host, endpoint.port);
  client.set_connection_timeout(
      std::chrono::milliseconds(static_cast<int64_t>(std::min(timeout_s, 5.0) * 1000)));
  client.set_read_timeout(std::chrono::milliseconds(static_cast<int64_t>(timeout_s * 1000)));
  client.set_write_timeout(std::chrono::milliseconds(static_cast<int64_t>(timeout_s * 1000)));
  client.set_keep_alive(false);
  return client;
}

std::string WithQuery(const std::string& path, const httplib::Request& req) {
  if (req.params.empty()) return path;
  std::string out = path;
  char separator = '?';
  for (const auto& [key, value] : req.params) {
    out += separator + httplib::detail::encode_query_param(key) + "=" +
           httplib::detail::encode_query_param(value);
    separator = '&';
  }
  return out;
}

}  // namespace

std::string RigEndpoint::Address() const {
  const bool v6 = host.find(':') != std::string::npos;
  return (v6 ? "[" + host + "]" : host) + ":" + std::to_string(port);
}

void ProxyRequest(const RigEndpoint& endpoint, const std::string& path, const httplib::Request& req,
                  httplib::Response& res, double timeout_s) {
  httplib::Client client = Connect(endpoint, timeout_s);
  httplib::Headers headers = {{kRigSecretHeader, endpoint.secret}};
  for (const char* name : {"X-Sirupp-Client", "X-Sirupp-Token"}) {
    if (req.has_header(name)) headers.emplace(name, req.get_header_value(name));
  }
  const std::string target = WithQuery(path, req);
  const std::string content_type = req.get_header_value("Content-Type").empty()
                                       ? "application/json"
                                       : req.get_header_value("Content-Type");
  const httplib::Result answer = req.method == "POST"
                                     ? client.Post(target, headers, req.body, content_type)
                                     : client.Get(target, headers);
  if (!answer) {
    panel::Send(
        panel::ErrorResponse(502, "the rig's node (" + endpoint.Address() +
                                      ") did not answer: " + httplib::to_string(answer.error())),
        res);
    return;
  }
  res.status = answer->status;
  res.set_header("Cache-Control", "no-store");
  const std::string type = answer->get_header_value("Content-Type");
  res.set_content(answer->body, type.empty() ? "application/octet-stream" : type.c_str());
}

void ProxyStream(const RigEndpoint& endpoint, const std::string& path_and_query,
                 httplib::Response& res, std::shared_ptr<void> keep,
                 std::function<bool()> still_wanted) {
  res.set_header("Cache-Control", "no-store");
  res.set_header("X-Accel-Buffering", "no");
  res.set_chunked_content_provider(
      "text/event-stream",
      [endpoint, path_and_query, keep, still_wanted](size_t, httplib::DataSink& sink) {
        // One call serves the whole stream: the node's chunks are written on as they come.
        httplib::Client client(endpoint.host, endpoint.port);
        client.set_connection_timeout(std::chrono::seconds(5));
        // The node sends ": idle" each second; 15 s without a byte is a node gone, not one
        // stalled by its load (a busy 2-core machine stalled a node's stream past 5 s).
        client.set_read_timeout(std::chrono::seconds(15));
        client.set_keep_alive(false);
        const httplib::Headers headers = {{kRigSecretHeader, endpoint.secret}};
        bool browser_gone = false;
        int status = 0;
        const httplib::Result answer = client.Get(
            path_and_query, headers,
            [&](const httplib::Response& head) {
              status = head.status;
              return head.status == 200;
            },
            [&](const char* data, size_t length) {
              if (!sink.is_writable() || !sink.write(data, length)) {
                browser_gone = true;
                return false;
              }
              return !still_wanted || still_wanted();
            });
        if (!browser_gone) {
          const std::string last =
              status != 0 && status != 200
                  ? ": the rig's node answered " + std::to_string(status) + "\n\n"
              : answer ? std::string(": the rig's stream ended\n\n")
                       : ": the rig's node stopped answering (" +
                             httplib::to_string(answer.error()) + ")\n\n";
          sink.write(last.data(), last.size());
          sink.done();
        }
        return !browser_gone;
      });
}

std::optional<nlohmann::json> FetchJson(const RigEndpoint& endpoint, const std::string& path,
                                        double timeout_s) {
  httplib::Client client = Connect(endpoint, timeout_s);
  const httplib::Result answer = client.Get(path, {{kRigSecretHeader, endpoint.secret}});
  if (!answer || answer->status != 200) return std::nullopt;
  nlohmann::json body = nlohmann::json::parse(answer->body, nullptr, false);
  if (body.is_discarded()) return std::nullopt;
  return body;
}

int PostJson(const RigEndpoint& endpoint, const std::string& path, const nlohmann::json& body,
             double timeout_s) {
  httplib::Client client = Connect(endpoint, timeout_s);
  const httplib::Result answer =
      client.Post(path, {{kRigSecretHeader, endpoint.secret}, {"X-Sirupp-Client", "class-server"}},
                  body.dump(), "application/json");
  return answer ? answer->status : 0;
}

}  // namespace sirupp::classroom
