#include "class/hub_api.hpp"

#include <fcntl.h>
#include <openssl/crypto.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>

#include "core/printable.hpp"

namespace sirupp::classroom {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

panel::Response JsonResponse(int status, const Json& body) {
  return panel::Response{status, "application/json", body.dump()};
}

bool SameSecret(const std::string& secret, const std::string& offered) {
  return !secret.empty() && offered.size() == secret.size() &&
         CRYPTO_memcmp(offered.data(), secret.data(), secret.size()) == 0;
}

// A string field of `body`, "" when absent; false (and `error` set) when present but not a string.
bool StringField(const Json& body, const char* key, std::string& out, std::string& error) {
  const auto it = body.find(key);
  if (it == body.end() || it->is_null()) return true;
  if (!it->is_string()) {
    error = std::string(key) + ": expected a string";
    return false;
  }
  out = it->get<std::string>();
  return true;
}

bool IsTokenText(const std::string& token) {
  return token.size() <= 256 && std::all_of(token.begin(), token.end(), [](char c) {
           return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z');
         });
}

// whoami by a student's class token (no front header came): the student it names.
panel::Response WhoByToken(const HubApiContext& context, const std::string& client,
                           const std::string& student, const std::string& token) {
  using Clock = BadTokenThrottle::Clock;
  if (student.empty() && token.empty()) {
    return panel::ErrorResponse(
        403,
        "not signed in: open Notebooks from your page on the class server (the address "
        "with your token that your teacher gave you)");
  }
  const std::string who = core::Printable(student, 40);
  const bool on_roster = std::find(context.config.students.begin(), context.config.students.end(),
                                   student) != context.config.students.end();
  if (!IsTokenText(token) || token.empty()) {
    context.throttle.Failed(client, student, Clock::now());
    return panel::ErrorResponse(403, "'" + core::Printable(token, 60) +
                                         "' is not a token; allowed: the letters and digits of "
                                         "the address your teacher gave you");
  }
  if (!on_roster) {
    context.throttle.Failed(client, student, Clock::now());
    return panel::ErrorResponse(403, "you are signed in as '" + who +
                                         "', who is not on the roster of the class " +
                                         context.config.name + "; ask your teacher");
  }
  if (!context.tokens.Check(student, token)) {
    context.throttle.Failed(client, student, Clock::now());
    context.log("hub: refused a bad token for " + student + " from " + core::Printable(client, 60));
    return panel::ErrorResponse(403, "this token does not open " + who + "'s notebooks");
  }
  context.throttle.Succeeded(client, student);
  context.log("hub: " + student + " signed in (token)");
  return JsonResponse(200, Json{{"name", student}});
}

panel::Response WhoAmI(const HubApiContext& context, const std::string& text) {
  using Clock = BadTokenThrottle::Clock;
  const Json body = Json::parse(text.empty() ? "{}" : text, nullptr, false);
  if (!body.is_object()) {
    return panel::ErrorResponse(400,
                                "body: expected a JSON object {peer, headers, student, token}");
  }
  std::string error;
  std::string peer;
  std::string student;
  std::string token;
  if (!StringField(body, "peer", peer, error) || !StringField(body, "student", student, error) ||
      !StringField(body, "token", token, error)) {
    return panel::ErrorResponse(400, error);
  }
  Json headers = Json::object();
  if (body.contains("headers")) {
    headers = body["headers"];
    if (!headers.is_object()) return panel::ErrorResponse(400, "headers: expected an object");
    for (const auto& [name, value] : headers.items()) {
      if (!value.is_string()) {
        return panel::ErrorResponse(400,
                                    "headers." + core::Printable(name, 40) + ": expected a string");
      }
    }
  }
  // Header names are case-insensitive; the values as the front sent them.
  const FrontAuth::HeaderOf header = [&headers](const std::string& name) -> std::string {
    for (const auto& [key, value] : headers.items()) {
      if (key.size() == name.size() &&
          std::equal(key.begin(), key.end(), name.begin(), [](char a, char b) {
            return std::tolower(static_cast<unsigned char>(a)) ==
                   std::tolower(static_cast<unsigned char>(b));
          })) {
        return value.get<std::string>();
      }
    }
    return "";
  };
  const std::string client = context.front.ClientAddress(peer, header);
  const double wait = context.throttle.WaitFor(client, Clock::now());
  if (wait > 0) {
    return panel::ErrorResponse(429, "too many bad tokens from " + core::Printable(client, 60) +
                                         "; try again in " +
                                         std::to_string(static_cast<int>(wait) + 1) + " s");
  }
  const FrontVerdict verdict = context.front.Judge(peer, header);
  if (verdict.kind == FrontVerdict::Kind::kRefused) {
    context.log("hub: refused a sign-in from " + core::Printable(client, 60) + ": " +
                verdict.reason);
    return panel::ErrorResponse(403, verdict.reason);
  }
  if (verdict.kind == FrontVerdict::Kind::kUser) {
    const std::string who = core::Printable(verdict.user, 60);
    const std::string role = context.front.RoleOf(verdict.user, context.config.students);
    if (role == "student") {
      context.log("hub: " + verdict.user + " signed in (front)");
      return JsonResponse(200, Json{{"name", verdict.user}});
    }
    if (role == "teacher") {
      return panel::ErrorResponse(
          403, "you are signed in as '" + who + "', a teacher of the class " + context.config.name +
                   ": notebook servers are for the class's students (your page: /teacher/)");
    }
    return panel::ErrorResponse(403, "you are signed in as '" + who +
                                         "', who is not on the roster of the class " +
                                         context.config.name + "; ask your teacher");
  }
  // No front header: the student's class token, for the student it names.
  return WhoByToken(context, client, student, token);
}

// The fields of a site inside a rig's job (none for a rig on this machine, whose answers stay
// as they were): the job, its node's address and name, the rig's bus there, the data folder there.
void AddJobSite(const NotebookSite& site, Json& answer) {
  if (site.job.empty()) return;
  answer["job"] = site.job;
  answer["host"] = site.host;
  answer["node"] = site.node;
  answer["lcm_url"] = site.lcm_url;
  answer["node_data"] = site.node_data;
}

panel::Response RigRoute(const HubApiContext& context, const std::string& student,
                         const std::string& verb) {
  if (!context.rigs.Has(student)) {
    return panel::ErrorResponse(404, "no student '" + core::Printable(student, 40) +
                                         "' in the class " + context.config.name);
  }
  context.rigs.Touch(student);
  if (verb == "touch") {
    // Where the rig is now ("" while it is stopped): a rig restarted on another bus is followed.
    Json answer{{"name", student}, {"ok", true}, {"lcm_url", context.rigs.LcmUrl(student)}};
    const NotebookSite site = context.rigs.Notebook(student);
    if (site.why_not.empty()) AddJobSite(site, answer);
    return JsonResponse(200, answer);
  }
  const std::string why = context.rigs.Ensure(student);
  if (!why.empty()) return panel::ErrorResponse(503, why);
  // Where the notebook server runs beside the rig is the rig's spawner's to say.
  const NotebookSite site = context.rigs.Notebook(student);
  if (!site.why_not.empty()) {
    // "starting": the rig is on its way (a job that has not reported yet); the hub asks again.
    return JsonResponse(503,
                        Json{{"ok", false}, {"error", site.why_not}, {"starting", site.starting}});
  }
  Json answer{{"name", student}, {"state", "running"}, {"lcm_url", site.lcm_url}};
  AddJobSite(site, answer);
  return JsonResponse(200, answer);
}

}  // namespace

std::string HubSecretFile(const ClassConfig& config) { return config.data_dir + "/hub.secret"; }

std::string EnsureHubSecret(const ClassConfig& config) {
  const std::string file = HubSecretFile(config);
  fs::create_directories(config.data_dir);
  if (!fs::exists(file)) {
    const std::string secret = RandomHex(24);
    const std::string temporary = file + ".tmp";
    const int fd = ::open(temporary.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
    if (fd < 0) throw std::runtime_error("cannot write the hub's secret " + temporary);
    const std::string line = secret + "\n";
    const bool written = ::write(fd, line.data(), line.size()) == static_cast<ssize_t>(line.size());
    ::fsync(fd);
    ::close(fd);
    if (!written) throw std::runtime_error("cannot write the hub's secret " + temporary);
    fs::rename(temporary, file);
  }
  struct stat info {};
  if (::stat(file.c_str(), &info) != 0) {
    throw std::runtime_error("cannot read the hub's secret " + file);
  }
  if ((info.st_mode & 077) != 0) {
    throw std::runtime_error("the hub's secret " + file +
                             " is readable by others; allowed: mode 0600 (chmod 600 it)");
  }
  std::ifstream in(file);
  std::string secret;
  std::getline(in, secret);
  if (secret.size() < 16) {
    throw std::runtime_error("the hub's secret " + file +
                             " is shorter than 16 characters; delete it for a new one");
  }
  return secret;
}

panel::Response HubApiRoute(const HubApiContext& context, const std::string& secret,
                            const std::string& offered, const std::string& method,
                            const std::string& rest, const std::string& body) {
  if (!SameSecret(secret, offered)) {
    return panel::ErrorResponse(
        403, std::string("the hub's API answers only the hub's secret (") + kHubSecretHeader + ")");
  }
  if (method != "POST") return panel::ErrorResponse(405, "/hub/api/" + rest + ": allowed: POST");
  if (rest == "whoami") return WhoAmI(context, body);
  const std::string prefix = "rigs/";
  if (rest.rfind(prefix, 0) == 0) {
    const std::string tail = rest.substr(prefix.size());
    const size_t slash = tail.find('/');
    if (slash != std::string::npos) {
      const std::string student = tail.substr(0, slash);
      const std::string verb = tail.substr(slash + 1);
      if (verb == "ensure" || verb == "touch") return RigRoute(context, student, verb);
    }
  }
  return panel::ErrorResponse(404, "no such hub API: /hub/api/" + core::Printable(rest, 100) +
                                       "; allowed: whoami, rigs/NAME/ensure, rigs/NAME/touch");
}

std::optional<std::string> NotebooksLink(const ClassConfig& config, const std::string& student,
                                         const std::string& token) {
  if (!config.notebooks || config.notebooks->hub_url.empty()) return std::nullopt;
  std::string link = config.notebooks->hub_url + "/hub/login";
  if (!token.empty()) link += "?student=" + student + "&token=" + token;
  return link;
}

}  // namespace sirupp::classroom
