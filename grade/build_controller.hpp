#pragma once
// Builds a student's controller from C++ source (one file, or a few, against
// include/sirupp/controller.h) into a library sirupp-control can load, with fixed flags, a time
// limit and, by default, inside the sandbox (sandbox/sandbox.hpp: the compiler sees /usr, the
// sources' folder and the include folder read-only, writes only the output folder, has no
// network). Used by `sirupp controller build`, `sirupp grade FILE.cpp`, `sirupp grade --batch`
// and the class server. docs/student-controllers.md.

#include <string>
#include <vector>

#include "sandbox/sandbox.hpp"

namespace sirupp::grade {

// One compiler error at its place, the file named as the student wrote it (relative to the
// sources' folder): "my_controller.cpp:12:5: error: expected ';' before '}' token".
struct CompilerError {
  std::string file;
  int line = 0;
  int column = 0;
  std::string message;
  std::string ToString() const;
};

struct BuildOptions {
  std::string include_dir;   // holds sirupp/controller.h
  double time_limit_s = 60;  // wall time; the compiler is killed after it
  bool sandbox = true;
  sandbox::Limits limits = {60, 2048, 16, 256, 256};
};

struct BuildResult {
  bool built = false;
  std::string library;                // OUT_DIR/NAME.so when built
  std::vector<CompilerError> errors;  // in the compiler's order
  std::string problem;                // "" when built; else one line: why not
  std::string log_file;               // the compiler's whole output (OUT_DIR/NAME.build.log)
  double seconds = 0;                 // wall time of the build
};

// The fixed command: g++ -std=c++17 -O2 -fPIC -shared -Wl,-z,defs -I INCLUDE SOURCES -o LIB.
std::vector<std::string> CompilerCommand(const std::vector<std::string>& sources,
                                         const std::string& include_dir,
                                         const std::string& library);

// Builds `sources` (all in one folder) into OUT_DIR/NAME.so. Throws std::runtime_error when the
// sandbox cannot be had (and options.sandbox is on) or the compiler cannot be started; a source
// that does not compile is a BuildResult with its errors.
BuildResult BuildController(const std::vector<std::string>& sources, const std::string& out_dir,
                            const std::string& name, const BuildOptions& options);

// The "file:line:column: error: text" lines of a compiler's output; `folder/` is taken off the
// file names.
std::vector<CompilerError> ParseCompilerErrors(const std::string& output,
                                               const std::string& folder);

}  // namespace sirupp::grade
