#pragma once
// Where a process finds the files shipped with SIRUPP-LCM (config/...).

#include <string>

namespace sirupp::runtime {

// Resolves a path to a shipped file (config/...): as given when it exists, else relative to the
// source tree the program was built from. Lets `sirupp demo` and every process work from any
// directory.
std::string ResolveDataPath(const std::string& path);

}  // namespace sirupp::runtime
