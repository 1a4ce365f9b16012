#include "class/front_auth.hpp"

#include <arpa/inet.h>
#include <openssl/crypto.h>
#include <sys/stat.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <utility>

#include "class/class_config.hpp"
#include "core/errors.hpp"
#include "core/printable.hpp"

namespace sirupp::classroom {
namespace {

namespace fs = std::filesystem;

constexpr size_t kMinSecretLength = 16;

// An address in 16 bytes (IPv4 as IPv4-mapped IPv6), or nullopt.
std::optional<std::array<unsigned char, 16>> ParseAddress(const std::string& text) {
  std::array<unsigned char, 16> out{};
  in_addr v4{};
  if (::inet_pton(AF_INET, text.c_str(), &v4) == 1) {
    out[10] = 0xff;
    out[11] = 0xff;
    std::memcpy(out.data() + 12, &v4, 4);
    return out;
  }
  in6_addr v6{};
  if (::inet_pton(AF_INET6, text.c_str(), &v6) == 1) {
    std::memcpy(out.data(), &v6, 16);
    return out;
  }
  return std::nullopt;
}

std::string Trim(const std::string& text) {
  const size_t begin = text.find_first_not_of(" \t\r\n");
  if (begin == std::string::npos) return "";
  return text.substr(begin, text.find_last_not_of(" \t\r\n") - begin + 1);
}

bool IsHeaderName(const std::string& name) {
  return !name.empty() && name.size() <= 64 && std::all_of(name.begin(), name.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '-';
  });
}

bool SameHeader(const std::string& a, const std::string& b) {
  return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](char x, char y) {
           return std::tolower(static_cast<unsigned char>(x)) ==
                  std::tolower(static_cast<unsigned char>(y));
         });
}

std::string ReadSecret(const core::YamlValue& value, const std::string& base_dir) {
  const std::string text = value.String();
  const fs::path path =
      fs::path(text).is_absolute() ? fs::path(text) : fs::absolute(base_dir) / text;
  struct stat info {};
  if (::stat(path.c_str(), &info) != 0 || !S_ISREG(info.st_mode)) {
    value.Fail("'" + text + "': no such file (looked for " + path.lexically_normal().string() +
               ")");
  }
  if ((info.st_mode & S_IRWXO) != 0) {
    std::ostringstream mode;
    mode << std::oct << (info.st_mode & 07777);
    value.Fail("'" + text + "' is readable by every account on this machine (mode 0" + mode.str() +
               "); allowed: readable only by its owner and group (chmod o-rwx), the service "
               "user and the front's administrator");
  }
  std::ifstream in(path);
  std::stringstream content;
  content << in.rdbuf();
  if (!in) value.Fail("'" + text + "' cannot be read by this user");
  const std::string secret = Trim(content.str());
  const bool printable =
      std::all_of(secret.begin(), secret.end(), [](char c) { return c > ' ' && c < 127; });
  if (secret.size() < kMinSecretLength || !printable) {
    value.Fail("'" + text + "' holds no usable secret; allowed: one line of at least " +
               std::to_string(kMinSecretLength) +
               " printable characters without spaces (e.g. openssl rand -hex 32)");
  }
  return secret;
}

}  // namespace

const std::vector<std::string>& FrontConfigKeys() {
  static const std::vector<std::string> keys = {"trusted_proxy", "proxy_user_header",
                                                "proxy_secret_file", "proxy_teachers"};
  return keys;
}

std::optional<FrontConfig> ReadFrontConfig(const core::YamlMap& server,
                                           const std::string& base_dir) {
  const auto address = server.Find("trusted_proxy");
  if (!address) {
    for (const std::string& key : FrontConfigKeys()) {
      if (const auto v = server.Find(key)) {
        v->Fail(key +
                " without trusted_proxy; give the front's address in trusted_proxy, or "
                "leave the proxy_* keys out");
      }
    }
    return std::nullopt;
  }
  FrontConfig front;
  front.address = address->String();
  if (!ParseAddress(front.address)) {
    address->Fail("'" + front.address +
                  "' is not an IP address; allowed: the front's IPv4 or IPv6 address as "
                  "digits (e.g. 127.0.0.1 or ::1), not a host name");
  }
  if (const auto v = server.Find("proxy_user_header")) {
    front.user_header = v->String();
    if (!IsHeaderName(front.user_header) || SameHeader(front.user_header, kFrontSecretHeader) ||
        SameHeader(front.user_header, "X-Sirupp-Token") ||
        SameHeader(front.user_header, "X-Forwarded-For")) {
      v->Fail("'" + front.user_header +
              "' is not a header for the user; allowed: letters, digits and '-' (up to 64), "
              "not X-Sirupp-Front-Secret, X-Sirupp-Token or X-Forwarded-For");
    }
  }
  const core::YamlValue secret = server.Get(
      "proxy_secret_file", "the file holding the secret the front sends in X-Sirupp-Front-Secret");
  front.secret = ReadSecret(secret, base_dir);
  front.secret_file =
      (fs::path(secret.String()).is_absolute() ? fs::path(secret.String())
                                               : fs::absolute(base_dir) / secret.String())
          .lexically_normal()
          .string();
  if (const auto v = server.Find("proxy_teachers")) {
    for (const core::YamlValue& entry : v->Sequence(0, 100)) {
      const std::string name = entry.String();
      if (!IsValidName(name) || name == kTeacher) {
        entry.Fail("'" + name +
                   "' is not a sign-in name; allowed: 1 to 32 letters, digits, '-', '_' and '.', "
                   "not 'teacher'");
      }
      front.teachers.push_back(name);
    }
  }
  return front;
}

bool SameAddress(const std::string& a, const std::string& b) {
  const auto x = ParseAddress(a);
  const auto y = ParseAddress(b);
  return x && y && *x == *y;
}

FrontAuth::FrontAuth(FrontConfig config) : config_(std::move(config)) {}

bool FrontAuth::FromFront(const std::string& peer) const {
  return config_ && SameAddress(peer, config_->address);
}

bool FrontAuth::RightSecret(const std::string& secret) const {
  return config_ && secret.size() == config_->secret.size() &&
         CRYPTO_memcmp(secret.data(), config_->secret.data(), secret.size()) == 0;
}

bool FrontAuth::Vouched(const std::string& peer, const HeaderOf& header) const {
  return FromFront(peer) && RightSecret(header(kFrontSecretHeader));
}

FrontVerdict FrontAuth::Judge(const std::string& peer, const HeaderOf& header) const {
  FrontVerdict verdict;
  if (!config_) return verdict;
  const std::string user = header(config_->user_header);
  const std::string secret = header(kFrontSecretHeader);
  if (user.empty() && secret.empty()) return verdict;  // tokens, as without a front
  verdict.kind = FrontVerdict::Kind::kRefused;
  if (!FromFront(peer)) {
    verdict.reason = "a sign-in header (" +
                     std::string(user.empty() ? kFrontSecretHeader : config_->user_header) +
                     ") from " + core::Printable(peer, 60) +
                     ", which is not this class's front; sign in through the front";
    return verdict;
  }
  if (secret.empty()) {
    verdict.reason = "the header " + config_->user_header +
                     " came without the front's secret; the front must add " + kFrontSecretHeader;
    return verdict;
  }
  if (!RightSecret(secret)) {
    verdict.reason = std::string("the front's secret (") + kFrontSecretHeader +
                     ") does not match " + config_->secret_file;
    return verdict;
  }
  if (user.empty()) {
    verdict.reason = "the front sent no user (header " + config_->user_header + ")";
    return verdict;
  }
  if (!IsValidName(user)) {
    // As sent (never decoded): "%61lice" is not alice.
    verdict.reason = "the front signed you in as '" + core::Printable(user, 60) + "' (header " +
                     config_->user_header +
                     "), which is not a name of this class's syntax; allowed: 1 to 32 letters, "
                     "digits, '-', '_' and '.', as the front sends it (no %-encoding)";
    return verdict;
  }
  verdict.kind = FrontVerdict::Kind::kUser;
  verdict.user = user;
  return verdict;
}

std::string FrontAuth::ClientAddress(const std::string& peer, const HeaderOf& header) const {
  if (!Vouched(peer, header)) return peer;
  const std::string forwarded_for = header("X-Forwarded-For");
  if (forwarded_for.empty()) return peer;
  const size_t comma = forwarded_for.rfind(',');
  const std::string last =
      Trim(comma == std::string::npos ? forwarded_for : forwarded_for.substr(comma + 1));
  return ParseAddress(last) ? last : peer;
}

std::string FrontAuth::RoleOf(const std::string& user,
                              const std::vector<std::string>& students) const {
  if (std::find(students.begin(), students.end(), user) != students.end()) return "student";
  if (config_ && std::find(config_->teachers.begin(), config_->teachers.end(), user) !=
                     config_->teachers.end()) {
    return "teacher";
  }
  return "";
}

}  // namespace sirupp::classroom
