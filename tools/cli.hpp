#pragma once
// The `sirupp` command-line front. Every subcommand is a function over the libraries; main() only
// forwards argv here. Exit codes: 0 success, 1 the command ran and failed, 2 bad arguments or bad
// input files (the message names the place).

#include <iosfwd>
#include <string>
#include <vector>

namespace sirupp::tools {

int RunCli(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

// Resolves a path to a shipped file (config/...): as given when it exists, else relative to the
// source tree the program was built from. Lets `sirupp demo` work from any directory.
std::string ResolveDataPath(const std::string& path);

}  // namespace sirupp::tools
