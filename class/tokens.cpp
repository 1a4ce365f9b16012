#include "class/tokens.hpp"

#include <fcntl.h>
#include <openssl/crypto.h>
#include <openssl/evp.h>
#include <openssl/rand.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>

#include "core/errors.hpp"

namespace sirupp::classroom {
namespace {

using Json = nlohmann::json;

std::string Hex(const unsigned char* data, size_t size) {
  static const char* const kDigits = "0123456789abcdef";
  std::string out;
  out.reserve(size * 2);
  for (size_t i = 0; i < size; ++i) {
    out += kDigits[data[i] >> 4];
    out += kDigits[data[i] & 15];
  }
  return out;
}

std::string NowIso() {
  const std::time_t now = std::time(nullptr);
  std::tm utc{};
  gmtime_r(&now, &utc);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", &utc);
  return text;
}

// Writes `text` to `file` with mode 0600 through a temporary file and a rename.
void WritePrivate(const std::string& file, const std::string& text) {
  const std::string temporary = file + ".tmp";
  const int fd = ::open(temporary.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
  if (fd < 0) throw std::runtime_error("cannot write " + temporary);
  size_t done = 0;
  while (done < text.size()) {
    const ssize_t n = ::write(fd, text.data() + done, text.size() - done);
    if (n <= 0) {
      ::close(fd);
      throw std::runtime_error("cannot write " + temporary);
    }
    done += static_cast<size_t>(n);
  }
  ::fsync(fd);
  ::close(fd);
  std::filesystem::rename(temporary, file);
}

}  // namespace

std::string Sha256Hex(const std::string& bytes) {
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned int size = 0;
  if (EVP_Digest(bytes.data(), bytes.size(), digest, &size, EVP_sha256(), nullptr) != 1) {
    throw std::runtime_error("SHA-256 failed (OpenSSL)");
  }
  return Hex(digest, size);
}

std::string RandomHex(int count) {
  std::string bytes(static_cast<size_t>(count), '\0');
  auto* data = reinterpret_cast<unsigned char*>(bytes.data());
  if (RAND_bytes(data, count) != 1)
    throw std::runtime_error("no random bytes (OpenSSL RAND_bytes)");
  return Hex(data, bytes.size());
}

TokenStore::TokenStore(std::string file) : file_(std::move(file)) { Load(); }

void TokenStore::Refresh() const {
  std::error_code error;
  const auto time = std::filesystem::last_write_time(file_, error);
  if (error || time == read_time_) return;
  try {
    Load();
  } catch (const std::exception&) {
    // A half-written or broken file: keep what was read before.
  }
}

void TokenStore::Load() const {
  std::error_code error;
  const auto time = std::filesystem::last_write_time(file_, error);
  if (error) return;
  const core::SourceLocation where{file_, 1, 1};
  Json json;
  try {
    std::ifstream in(file_);
    json = Json::parse(in);
  } catch (const std::exception& e) {
    throw core::ConfigError(where, "", std::string("not a tokens file: ") + e.what());
  }
  if (!json.is_object())
    throw core::ConfigError(where, "", "not a tokens file: expected an object");
  std::map<std::string, Entry> entries;
  for (const auto& [name, entry] : json.items()) {
    if (!entry.is_object() || !entry.contains("salt") || !entry.contains("sha256") ||
        !entry["salt"].is_string() || !entry["sha256"].is_string()) {
      throw core::ConfigError(where, name, "expected {salt, sha256, issued} strings");
    }
    std::string issued;
    if (entry.contains("issued") && entry.at("issued").is_string()) {
      issued = entry.at("issued").get<std::string>();
    }
    entries[name] =
        Entry{entry.at("salt").get<std::string>(), entry.at("sha256").get<std::string>(), issued};
  }
  entries_ = std::move(entries);
  read_time_ = time;
}

std::string TokenStore::Issue(const std::string& name) {
  const std::string token = RandomHex(24);
  const std::lock_guard<std::mutex> lock(mutex_);
  Refresh();
  Entry entry;
  entry.salt = RandomHex(16);
  entry.hash = Sha256Hex(entry.salt + token);
  entry.issued = NowIso();
  entries_[name] = entry;
  Save();
  return token;
}

bool TokenStore::Has(const std::string& name) const {
  const std::lock_guard<std::mutex> lock(mutex_);
  Refresh();
  return entries_.count(name) != 0;
}

bool TokenStore::Check(const std::string& name, const std::string& token) const {
  if (token.empty() || token.size() > 256) return false;
  Entry entry;
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    Refresh();
    const auto found = entries_.find(name);
    if (found == entries_.end()) return false;
    entry = found->second;
  }
  const std::string hash = Sha256Hex(entry.salt + token);
  return hash.size() == entry.hash.size() &&
         CRYPTO_memcmp(hash.data(), entry.hash.data(), hash.size()) == 0;
}

std::vector<std::string> TokenStore::Names() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  std::vector<std::string> out;
  for (const auto& [name, entry] : entries_) out.push_back(name);
  return out;
}

void TokenStore::Save() {
  Json json = Json::object();
  for (const auto& [name, entry] : entries_) {
    json[name] = Json{{"salt", entry.salt}, {"sha256", entry.hash}, {"issued", entry.issued}};
  }
  WritePrivate(file_, json.dump(2) + "\n");
  std::error_code error;
  read_time_ = std::filesystem::last_write_time(file_, error);
}

double BadTokenThrottle::WaitFor(const std::string& address, Clock::time_point now) {
  const std::lock_guard<std::mutex> lock(mutex_);
  const auto found = states_.find(address);
  if (found == states_.end() || found->second.locked_until <= now) return 0;
  return std::chrono::duration<double>(found->second.locked_until - now).count();
}

void BadTokenThrottle::Failed(const std::string& address, const std::string& page,
                              Clock::time_point now) {
  const std::lock_guard<std::mutex> lock(mutex_);
  if (states_.size() > 100000) states_.clear();  // bounded memory whatever the traffic
  State& state = states_[address];
  // A quiet hour forgives.
  if (state.failures > 0 && now - state.last > std::chrono::hours(1)) state = State{};
  state.last = now;
  ++state.failures;
  if (state.by_page.size() < 1000) ++state.by_page[page];
  if (state.failures >= kFreeFailures) {
    const double lockout = std::min(kMaxLockoutS, std::pow(2.0, state.failures - kFreeFailures));
    state.locked_until =
        now + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(lockout));
  }
}

void BadTokenThrottle::Succeeded(const std::string& address, const std::string& page) {
  const std::lock_guard<std::mutex> lock(mutex_);
  const auto found = states_.find(address);
  if (found == states_.end()) return;
  State& state = found->second;
  const auto mine = state.by_page.find(page);
  if (mine != state.by_page.end()) {
    state.failures -= mine->second;
    state.by_page.erase(mine);
  }
  // The lock-out stands as it was set (a right token is looked at only after it); once the
  // count is below the free failures, the next failure starts no lock-out.
  if (state.failures <= 0) states_.erase(found);
}

void AppendHandout(const std::string& file,
                   const std::vector<std::pair<std::string, std::string>>& rows) {
  const bool fresh = !std::filesystem::exists(file);
  const int fd = ::open(file.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0600);
  if (fd < 0) throw std::runtime_error("cannot write " + file);
  std::string text = fresh ? "student,address\n" : "";
  for (const auto& [name, address] : rows) text += name + "," + address + "\n";
  const ssize_t n = ::write(fd, text.data(), text.size());
  ::close(fd);
  if (n != static_cast<ssize_t>(text.size())) throw std::runtime_error("cannot write " + file);
}

}  // namespace sirupp::classroom
