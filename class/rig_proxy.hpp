#pragma once
// The class server's side of a rig that runs elsewhere (a job on a cluster node,
// class/rig_job.hpp): the student's API requests and live event stream forwarded to the rig's HTTP
// endpoint with the rig's secret, so the student's address, token and page stay what they are for a
// local rig. The stream is passed on as it arrives (each chunk written to the browser at once, no
// buffering).

#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "panel/http_glue.hpp"

namespace sirupp::classroom {

// Where a rig's endpoint is, and the secret it answers to.
struct RigEndpoint {
  std::string host;
  int port = 0;
  std::string secret;
  std::string Address() const;  // "host:port" ("[::1]:port" for IPv6)
};

// Forwards `req` (method, query, body, X-Sirupp-Client, Content-Type) to the endpoint's `path`
// and writes its answer into `res`. A node that does not answer is a 502 naming it.
void ProxyRequest(const RigEndpoint& endpoint, const std::string& path, const httplib::Request& req,
                  httplib::Response& res, double timeout_s = 20);

// Makes `res` the node's event stream at `path` (query included), chunk for chunk as it arrives;
// ends when the node's stream ends, the browser goes, or `still_wanted` says no (checked at each
// chunk and each idle second). `keep` is held while the stream is open.
void ProxyStream(const RigEndpoint& endpoint, const std::string& path_and_query,
                 httplib::Response& res, std::shared_ptr<void> keep,
                 std::function<bool()> still_wanted);

// GET of a JSON answer (the teacher's live view of the rig); none when the node does not answer
// in time or answers anything else.
std::optional<nlohmann::json> FetchJson(const RigEndpoint& endpoint, const std::string& path,
                                        double timeout_s);

// POST of a JSON body (the teacher's e-stop of every rig); the answer's status, 0 when none.
int PostJson(const RigEndpoint& endpoint, const std::string& path, const nlohmann::json& body,
             double timeout_s);

}  // namespace sirupp::classroom
