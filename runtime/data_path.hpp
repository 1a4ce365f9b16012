#pragma once
// Where a process finds the files shipped with SIRUPP-LCM (config/..., panel/web, class/web,
// include/sirupp/controller.h, notebooks/, examples/).

#include <string>

#include "runtime/args.hpp"

namespace sirupp::runtime {

// The robot model every process and command uses when --model is not given.
inline constexpr const char* kDefaultModelFile = "config/robots/puma260.yaml";

// The declaration of --model FILE, and its value resolved (kDefaultModelFile when absent).
Flag ModelFlag();
std::string ModelFileArg(const Args& args);

// Resolves a path to a shipped file (e.g. "config/robots/puma260.yaml"): as given when it exists
// or is absolute, else inside DataDir(); as given when it is in neither (the caller's error then
// names the path the user wrote). Lets `sirupp demo` and every process work from any directory.
std::string ResolveDataPath(const std::string& path);

// The folder the shipped files come from, decided once per process:
//   1. $SIRUPP_DATA_DIR when set and not empty;
//   2. the source tree, when this program (or the shared object holding this code, e.g. the
//      Python module) lies inside the build tree it was built in: development as before;
//   3. installed: <prefix>/share/sirupp, <prefix> the nearest folder above the program (or module)
//      that has one (/usr/bin/sirupp -> /usr/share/sirupp; a staged install in /tmp/x/usr works
//      the same), else the data folder of the prefix configured at build time.
// An installed program never falls back to the source tree, so a missing installed file shows.
std::string DataDir();

// How DataDir() was chosen, for messages: "SIRUPP_DATA_DIR", "build tree" or "installed".
std::string DataDirOrigin();

}  // namespace sirupp::runtime
