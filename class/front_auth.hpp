#pragma once
// Sign-in by the university's front (docs/install.md "A front with the university's sign-in"):
// a web server in front of the class server (Apache with mod_auth_openidc or Shibboleth, nginx
// with auth_request) signs the user in and passes the name in a header. The class server believes
// that header only on a request that comes from the front's address AND carries the secret the
// front adds (a file only the service user and the front's administrator can read), so no other
// program on the machine can pose as the front; the same holds for X-Forwarded-For (believed only
// with the secret: anyone can connect from the front's address). Values are compared as sent
// (class/http_guard.hpp keeps them undecoded). Without a front (no server.trusted_proxy in the
// class file) nothing changes: tokens, as before.
//
// In the class file:
//   server:
//     trusted_proxy: 127.0.0.1           # the front's address (an IPv4 or IPv6 literal)
//     proxy_user_header: X-Remote-User   # the header holding the signed-in user (the default)
//     proxy_secret_file: front.secret    # the secret, one line of >= 16 characters; relative to
//                                        # the class file's folder; not readable by others
//     proxy_teachers: [jsmith]           # sign-in names that open the teacher's page
// The front sends the secret in the header X-Sirupp-Front-Secret (kFrontSecretHeader).

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "core/yaml_reader.hpp"

namespace sirupp::classroom {

inline constexpr const char* kFrontSecretHeader = "X-Sirupp-Front-Secret";
inline constexpr const char* kDefaultUserHeader = "X-Remote-User";

struct FrontConfig {
  std::string address;  // the front's address, as written (a literal IP)
  std::string user_header = kDefaultUserHeader;
  std::string secret_file;  // absolute
  std::string secret;       // its content, surrounding white space removed
  std::vector<std::string> teachers;
};

// Reads trusted_proxy and the proxy_* keys of the class file's `server:` mapping (the caller has
// checked the keys are allowed). std::nullopt when trusted_proxy is absent; the other keys without
// it are an error naming them. Bad values fail at their place (file:line:col, value, allowed).
std::optional<FrontConfig> ReadFrontConfig(const core::YamlMap& server,
                                           const std::string& base_dir);

// The keys ReadFrontConfig reads, for the `server:` mapping's allowed keys.
const std::vector<std::string>& FrontConfigKeys();

// What a request's headers say about who sent it.
struct FrontVerdict {
  enum class Kind {
    kNoFront,  // no front header: the request is judged by its token, as without a front
    kUser,     // signed in by the front as `user`
    kRefused,  // front headers that cannot be believed: 403 with `reason`
  };
  Kind kind = Kind::kNoFront;
  std::string user;
  std::string reason;
};

class FrontAuth {
 public:
  // No front: every request is kNoFront, and a request's client is its peer.
  FrontAuth() = default;
  explicit FrontAuth(FrontConfig config);

  bool enabled() const { return config_.has_value(); }

  using HeaderOf = std::function<std::string(const std::string&)>;

  // Judges a request from `peer` (the TCP peer's address) with its headers (`header(name)`: the
  // value as sent, "" when absent; class/http_guard.hpp keeps them undecoded). With a front:
  // from the front's address with the right secret (compared byte for byte), the user header is
  // the user, refused when empty or not a name of the class's syntax (1 to 32 letters, digits,
  // '-', '_', '.'; the 403 names the value as it came); from the front with a wrong secret, or
  // with the user header but no secret, refused; from any other address, any front header (the
  // user header or the secret) is refused; no front header at all is kNoFront (tokens still
  // work, e.g. for the teacher on the server itself).
  FrontVerdict Judge(const std::string& peer, const HeaderOf& header) const;

  // True when the request comes from the front's address with the front's secret: only then is
  // anything the front adds (the user, X-Forwarded-For) believed.
  bool Vouched(const std::string& peer, const HeaderOf& header) const;

  // The client's address for the bad-token throttle, the connection caps and the log: the last
  // address the front added to X-Forwarded-For on a request the front vouches for (Vouched),
  // else the peer. A client's own X-Forwarded-For is never believed, nor one from the front's
  // address without the secret (any program on the machine can connect from there).
  std::string ClientAddress(const std::string& peer, const HeaderOf& header) const;

  // The role a signed-in name has: "student" (a student of `students`), "teacher" (in
  // proxy_teachers), or "" (not in the class).
  std::string RoleOf(const std::string& user, const std::vector<std::string>& students) const;

  const std::optional<FrontConfig>& config() const { return config_; }

 private:
  bool FromFront(const std::string& peer) const;
  bool RightSecret(const std::string& secret) const;
  std::optional<FrontConfig> config_;
};

// True when `a` and `b` are the same IP address ("::ffff:127.0.0.1" is 127.0.0.1); false when
// either is not an address.
bool SameAddress(const std::string& a, const std::string& b);

}  // namespace sirupp::classroom
