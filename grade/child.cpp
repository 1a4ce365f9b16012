#include "grade/child.hpp"

namespace sirupp::grade {

void Child::Start(const std::vector<std::string>& argv, const std::string& log_file) {
  proc::ProcessSpec spec;
  spec.argv = argv;
  spec.log_path = log_file;
  spec.death_signal = SIGKILL;  // nothing outlives a killed grader
  spec.group_ends_with_it = true;
  proc::Child::Start(spec);
}

}  // namespace sirupp::grade
