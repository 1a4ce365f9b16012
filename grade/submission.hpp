#pragma once
// One student's submission folder for `sirupp grade --batch DIR` (docs/grading.md):
//   command    a process controller: one line, the command with placeholders; words starting
//              with "./" are taken relative to the folder
//   *.so       a controller library (the first by name)
//   *.py       else, a controller written in Python (the first by name; python/)
//   *.cpp      a library's sources, built here with g++ against include/sirupp/controller.h
//   args       optional: --controller-args for a library
// Anything else, a failed build or an empty folder is a problem with the reason.

#include <string>

#include "grade/runner.hpp"

namespace sirupp::grade {

struct FoundController {
  ControllerSpec spec;
  std::string problem;  // "" when spec is usable
};

// `include_dir`: the folder holding sirupp/controller.h; `build_dir`: where a built library goes.
FoundController FindSubmission(const std::string& folder, const std::string& include_dir,
                               const std::string& build_dir);

}  // namespace sirupp::grade
