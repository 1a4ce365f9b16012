#pragma once
// `sirupp fk` and `sirupp ik`: forward and inverse kinematics from the command line.

#include <iosfwd>
#include <string>
#include <vector>

namespace sirupp::tools {

extern const char* const kFkAbout;
extern const char* const kIkAbout;

int RunFk(const std::vector<std::string>& args, std::ostream& out);
int RunIk(const std::vector<std::string>& args, std::ostream& out);

}  // namespace sirupp::tools
