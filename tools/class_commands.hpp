#pragma once
// `sirupp class serve|tokens|check|notebooks CLASS.yaml`: the class server (class/) from the
// command line.

#include <iosfwd>
#include <string>
#include <vector>

namespace sirupp::tools {

int RunClassServe(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);
int RunClassTokens(const std::vector<std::string>& args, std::ostream& out);
int RunClassCheck(const std::vector<std::string>& args, std::ostream& out);
int RunClassNotebooks(const std::vector<std::string>& args, std::ostream& out);

}  // namespace sirupp::tools
