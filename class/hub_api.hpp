#pragma once
// The notebooks hub's internal API on the class server (docs/notebooks.md, hub/README.md): the
// JupyterHub beside the class server asks it who a browser is and where that student's rig runs,
// so the roster, the tokens and the front's rules stay here, in one place.
//
//   POST /hub/api/whoami            {peer, headers: {NAME: VALUE}, student, token}: the browser's
//                                   credentials as the hub got them (the front's user header
//                                   with the front's secret, judged exactly as class/front_auth
//                                   judges a page's request from `peer`; or a student's class
//                                   token) -> 200 {name} or 403 {error} naming who they are
//                                   signed in as and why that opens no notebooks
//   POST /hub/api/rigs/NAME/ensure  the student's rig started unless it runs (as their page visit
//                                   does) -> 200 {name, state, lcm_url}; for a rig in a job
//                                   also {job, host, node, node_data} (NotebookSite: the server
//                                   runs as a step of that job, lcm_url is the bus on its node);
//                                   503 {error} with why it cannot, {starting: true} while the
//                                   rig's job has not reported yet (the hub asks again)
//   POST /hub/api/rigs/NAME/touch   the notebook server is in use: the rig is not idle
//                                   -> 200 {name, ok, lcm_url} (where the rig is now; "" stopped),
//                                   with the job's fields as ensure gives them
//
// Every request carries the hub's secret in X-Sirupp-Hub-Secret (DATA/hub.secret, 0600, made on
// the first serve of a class with notebooks:, compared in constant time); anything else is 403.
// The secret is never shown on a page.

#include <functional>
#include <optional>
#include <string>

#include "class/class_config.hpp"
#include "class/front_auth.hpp"
#include "class/rig_pool.hpp"
#include "class/tokens.hpp"
#include "panel/panel_api.hpp"

namespace sirupp::classroom {

inline constexpr const char* kHubSecretHeader = "X-Sirupp-Hub-Secret";

// DATA/hub.secret: the secret the hub sends.
std::string HubSecretFile(const ClassConfig& config);
// The hub's secret, made (48 random hex digits, mode 0600) when the file is missing; throws
// std::runtime_error naming the file when it cannot be read or made, or is readable by others.
std::string EnsureHubSecret(const ClassConfig& config);

// What the hub's routes need of the class server.
struct HubApiContext {
  const ClassConfig& config;
  const TokenStore& tokens;
  const FrontAuth& front;
  BadTokenThrottle& throttle;
  RigPool& rigs;
  std::function<void(const std::string& line)> log;
};

// Answers `method` on /hub/api/`rest` with the hub's `secret` as `offered` (the header's value as
// sent). Never throws for a bad request: 400 naming the field, 403, 404, 405, 503.
panel::Response HubApiRoute(const HubApiContext& context, const std::string& secret,
                            const std::string& offered, const std::string& method,
                            const std::string& rest, const std::string& body);

// The "Notebooks" link of a student's page: notebooks.hub_url's login, with the student's name and
// the token their request carried ("" when the front signed them in; the hub passes both back to
// whoami); std::nullopt without notebooks.hub_url.
std::optional<std::string> NotebooksLink(const ClassConfig& config, const std::string& student,
                                         const std::string& token);

}  // namespace sirupp::classroom
