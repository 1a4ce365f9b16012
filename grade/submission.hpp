#pragma once
// One student's submission folder for `sirupp grade --batch DIR` (docs/grading.md):
//   command    a process controller: one line, the command with placeholders; words starting
//              with "./" are taken relative to the folder
//   *.so       a controller library (the first by name)
//   *.py       else, a controller written in Python (the first by name; python/)
//   *.cpp      a library's sources, built with g++ against include/sirupp/controller.h
//              (grade/build_controller.hpp: fixed flags, a time limit, in the sandbox)
//   args       optional: --controller-args for a library
// Anything else, a failed build or an empty folder is a problem with the reason.

#include <string>

#include "grade/runner.hpp"

namespace sirupp::grade {

struct FoundController {
  ControllerSpec spec;
  std::string problem;  // "" when spec is usable
};

// `include_dir`: the folder holding sirupp/controller.h; a built library goes to
// `build_dir`/NAME/NAME.so (a folder per submission: the library's host sees its own only).
// `sandbox`: build in the sandbox, and run the library in it (ControllerSpec::sandbox).
FoundController FindSubmission(const std::string& folder, const std::string& include_dir,
                               const std::string& build_dir, bool sandbox = true);

}  // namespace sirupp::grade
