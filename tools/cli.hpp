#pragma once
// The `sirupp` command-line front. Every subcommand is a function over the libraries; main() only
// forwards argv here. Exit codes: 0 success, 1 the command ran and failed, 2 bad arguments or bad
// input files (the message names the place).

#include <iosfwd>
#include <string>
#include <vector>

namespace sirupp::tools {

int RunCli(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

}  // namespace sirupp::tools
