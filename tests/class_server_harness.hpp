#pragma once
// The class server in a test's process (tests/test_class.cpp, test_class_turns.cpp,
// test_submissions.cpp): bound to 127.0.0.1 on any free port, serving this tree's pages
// (panel/web, class/web, config/) with the rigs' programs from SIRUPP_BIN_DIR (ctest sets it),
// every token issued, served from a thread of its own, and an HTTP client on it. Stop() ends it
// (the destructor too).

#include <stdlib.h>

#include <filesystem>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <thread>

#include "class/class_config.hpp"
#include "class/class_server.hpp"
#include "core/errors.hpp"
#include "panel/httplib_include.hpp"

namespace sirupp::testing {

// A new folder under the temporary directory, named STEM-XXXXXX.
inline std::string TempDir(const std::string& stem) {
  std::string pattern = (std::filesystem::temp_directory_path() / (stem + "-XXXXXX")).string();
  if (::mkdtemp(pattern.data()) == nullptr) throw std::runtime_error("mkdtemp " + pattern);
  return pattern;
}

// A class of two (alice, bob) on any free port; data in class-data under the given folder.
inline constexpr const char* kClassOfTwo =
    "class: robotics-1\n"
    "robot: config/robots/puma260.yaml\n"
    "students: [alice, bob]\n"
    "data: class-data\n"
    "limits: {max_rigs: 2, idle_timeout_s: 60}\n"
    "server: {port: 0}\n";

// The error a class file's text gives (core::ConfigError's what()), or "".
inline std::string ClassFileError(const std::string& text) {
  try {
    classroom::ParseClassConfig(text, "c.yaml", std::filesystem::current_path().string());
  } catch (const core::ConfigError& e) {
    return e.what();
  }
  return "";
}

class TestClassServer {
 public:
  TestClassServer(const classroom::ClassConfig& config, const std::string& bin_dir,
                  int read_timeout_s) {
    namespace fs = std::filesystem;
    classroom::ServeOptions options;
    options.bin_dir = bin_dir;
    options.panel_web_dir = fs::absolute("panel/web").string();
    options.class_web_dir = fs::absolute("class/web").string();
    options.config_dir = fs::absolute("config").string();
    server = std::make_unique<classroom::ClassServer>(config, options);
    port = server->Bind();
    for (const auto& [name, address] : classroom::IssueMissingTokens(config, port)) {
      tokens[name] = address.substr(address.find("token=") + 6);
    }
    serving_ = std::thread([this] { server->Serve(); });
    client = std::make_unique<httplib::Client>("127.0.0.1", port);
    client->set_read_timeout(read_timeout_s, 0);
  }
  ~TestClassServer() { Stop(); }
  TestClassServer(const TestClassServer&) = delete;
  TestClassServer& operator=(const TestClassServer&) = delete;

  void Stop() {
    if (server) server->Stop();
    if (serving_.joinable()) serving_.join();
  }

  std::unique_ptr<classroom::ClassServer> server;
  int port = 0;
  std::map<std::string, std::string> tokens;  // teacher and every student
  std::unique_ptr<httplib::Client> client;

 private:
  std::thread serving_;
};

}  // namespace sirupp::testing
