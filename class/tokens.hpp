#pragma once
// The class's tokens: one per student and one for the teacher, random (OpenSSL's RAND_bytes, 24
// bytes as 48 hex digits), stored only as a salted SHA-256 (DATA/tokens.json, mode 0600), so a
// leaked copy of that file does not give them away. A token is shown once, when it is issued: the
// server appends it to the teacher's handout (DATA/tokens.csv, mode 0600: student,address).
//
// Bad-token slowing (BadTokenThrottle): per client address, after kFreeFailures wrong tokens every
// further request is refused without looking at its token for a lockout that doubles with each
// further failure (1 s, 2 s, ... up to 5 min). A right token forgives only the failures on its
// own page (a student's /s/NAME/, or the teacher's): a student's good token does not clear the
// count of guesses at another student's token from the same address.

#include <chrono>
#include <filesystem>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

namespace sirupp::classroom {

// Lower-case hex of SHA-256(bytes).
std::string Sha256Hex(const std::string& bytes);
// `count` random bytes from the system's generator as 2*count hex digits; throws when it fails.
std::string RandomHex(int count);

class TokenStore {
 public:
  // Reads `file` when it exists (throws core::ConfigError naming it when it is not ours). The file
  // is read again when it changes (a token reissued by another process counts at once).
  explicit TokenStore(std::string file);

  // A new token for `name` (replacing any other), saved at once. Returns the token itself.
  std::string Issue(const std::string& name);
  bool Has(const std::string& name) const;
  // True when `token` is `name`'s present token (constant-time comparison of the hashes).
  bool Check(const std::string& name, const std::string& token) const;
  std::vector<std::string> Names() const;
  const std::string& file() const { return file_; }

 private:
  struct Entry {
    std::string salt;
    std::string hash;
    std::string issued;  // ISO time
  };
  void Save();
  void Load() const;
  // Reads the file again when it changed since it was read (caller holds mutex_). A file that no
  // longer reads keeps the tokens in memory.
  void Refresh() const;

  std::string file_;
  mutable std::filesystem::file_time_type read_time_{};
  mutable std::mutex mutex_;
  mutable std::map<std::string, Entry> entries_;
};

class BadTokenThrottle {
 public:
  using Clock = std::chrono::steady_clock;
  static constexpr int kFreeFailures = 5;
  static constexpr double kMaxLockoutS = 300;

  // Seconds the address must still wait before its token is looked at; 0 = go ahead.
  double WaitFor(const std::string& address, Clock::time_point now);
  // A wrong token from `address` for `page` (the student whose page it was, or "teacher").
  void Failed(const std::string& address, const std::string& page, Clock::time_point now);
  // A right token from `address` for `page`: that page's failures are forgiven, no others.
  void Succeeded(const std::string& address, const std::string& page);
  // The same with one page for every token.
  void Failed(const std::string& address, Clock::time_point now) { Failed(address, "", now); }
  void Succeeded(const std::string& address) { Succeeded(address, ""); }

 private:
  struct State {
    int failures = 0;  // every page's
    std::map<std::string, int> by_page;
    Clock::time_point locked_until{};
    Clock::time_point last{};
  };
  std::mutex mutex_;
  std::map<std::string, State> states_;
};

// Appends "name,address" rows to the teacher's handout file (made with mode 0600 and a header).
void AppendHandout(const std::string& file,
                   const std::vector<std::pair<std::string, std::string>>& rows);

}  // namespace sirupp::classroom
