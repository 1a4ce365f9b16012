// sirupp-sandbox-exec: the two small steps of the sandbox that bubblewrap does not take
// (sandbox/sandbox.hpp). Started by the sandbox's argv prefix, never by hand:
//
//   sirupp-sandbox-exec [--cpu S] [--memory MB] [--processes N] [--file-size MB] [--sanitized]
//                       [--user UID] [--no-network] -- PROGRAM ARGS...
//
// in that order: the rlimits, (as root) become uid/gid UID, the socket filter, the memory limit,
// exec.
//
// Descriptors stay open across it. Exit 126 with one line when a step fails (nothing runs).

#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

#include "sandbox/sandbox.hpp"

namespace {

int Fail(const std::string& what) {
  std::fprintf(stderr, "sirupp-sandbox-exec: %s\n", what.c_str());
  return 126;
}

bool ParseNumber(const char* text, double* value) {
  char* end = nullptr;
  *value = std::strtod(text, &end);
  return end != text && *end == '\0' && *value >= 0;
}

}  // namespace

int main(int argc, char** argv) {
  sirupp::sandbox::Limits limits;
  bool apply_limits = false, sanitized = false, no_network = false;
  int user = -1;
  int i = 1;
  for (; i < argc; ++i) {
    const std::string flag = argv[i];
    if (flag == "--") break;
    if (flag == "--sanitized") {
      sanitized = true;
      continue;
    }
    if (flag == "--no-network") {
      no_network = true;
      continue;
    }
    double value = 0;
    if (i + 1 >= argc || !ParseNumber(argv[i + 1], &value)) {
      return Fail("'" + flag + "' needs a number (usage: see sandbox/exec_main.cpp)");
    }
    ++i;
    if (flag == "--user") {
      user = static_cast<int>(value);
    } else if (flag == "--cpu") {
      limits.cpu_s = value;
      apply_limits = true;
    } else if (flag == "--memory") {
      limits.memory_mb = static_cast<uint64_t>(value);
      apply_limits = true;
    } else if (flag == "--processes") {
      limits.processes = static_cast<int>(value);
      apply_limits = true;
    } else if (flag == "--file-size") {
      limits.file_size_mb = static_cast<uint64_t>(value);
      apply_limits = true;
    } else {
      return Fail("unknown option '" + flag + "'");
    }
  }
  if (i + 1 >= argc) return Fail("no command after --");
  if (apply_limits) {
    if (const std::string problem = sirupp::sandbox::ApplyLimits(limits, sanitized);
        !problem.empty()) {
      return Fail(problem);
    }
  }
  if (user >= 0) {
    if (const std::string problem = sirupp::sandbox::DropTo(user); !problem.empty()) {
      return Fail(problem);
    }
  }
  if (no_network) {
    if (const std::string problem = sirupp::sandbox::ForbidNetworkSockets(); !problem.empty()) {
      return Fail(problem);
    }
  }
  if (apply_limits) {
    if (const std::string problem = sirupp::sandbox::ApplyMemoryLimit(limits, sanitized);
        !problem.empty()) {
      return Fail(problem);
    }
  }
  ::execv(argv[i + 1], argv + i + 1);
  return Fail(std::string("cannot run ") + argv[i + 1] + ": " + std::strerror(errno));
}
