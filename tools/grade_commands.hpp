#pragma once
// `sirupp grade`: score a student's controller against a suite, beside the PIC-SERVO baseline
// (grade/, docs/grading.md).

#include <iosfwd>
#include <string>
#include <vector>

namespace sirupp::tools {

extern const char* const kGradeAbout;

int RunGrade(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

// `sirupp controller build FILE.cpp --out DIR` (grade/build_controller.hpp).
extern const char* const kControllerBuildAbout;
int RunControllerBuild(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

}  // namespace sirupp::tools
