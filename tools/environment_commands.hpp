#pragma once
// `sirupp env check` and `sirupp env show`: environment files (objects around the robot) from the
// command line.

#include <iosfwd>
#include <string>
#include <vector>

namespace sirupp::tools {

extern const char* const kEnvAbout;

// args: the words after "env". Exit 0 when every file loads, 2 with one error line per bad file;
// bad arguments throw core::UsageError (exit 2).
int RunEnv(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

}  // namespace sirupp::tools
