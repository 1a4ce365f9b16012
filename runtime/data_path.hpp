#pragma once
// Where a process finds the files shipped with SIRUPP-LCM (config/...).

#include <string>

#include "runtime/args.hpp"

namespace sirupp::runtime {

// The robot model every process and command uses when --model is not given.
inline constexpr const char* kDefaultModelFile = "config/robots/puma260.yaml";

// The declaration of --model FILE, and its value resolved (kDefaultModelFile when absent).
Flag ModelFlag();
std::string ModelFileArg(const Args& args);

// Resolves a path to a shipped file (config/...): as given when it exists, else relative to the
// source tree the program was built from. Lets `sirupp demo` and every process work from any
// directory.
std::string ResolveDataPath(const std::string& path);

}  // namespace sirupp::runtime
