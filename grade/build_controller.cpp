#include "grade/build_controller.hpp"

#include <unistd.h>

#include <cctype>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "core/errors.hpp"
#include "grade/child.hpp"

namespace sirupp::grade {
namespace fs = std::filesystem;

std::string CompilerError::ToString() const {
  return file + ":" + std::to_string(line) + ":" + std::to_string(column) + ": error: " + message;
}

std::vector<std::string> CompilerCommand(const std::vector<std::string>& sources,
                                         const std::string& include_dir,
                                         const std::string& library) {
  std::vector<std::string> argv = {"/usr/bin/g++",
                                   "-std=c++17",
                                   "-O2",
                                   "-fPIC",
                                   "-shared",
                                   "-Wl,-z,defs",  // a missing definition fails here, not at load
                                   "-fdiagnostics-plain-output",
                                   "-fmax-errors=20",
                                   "-I",
                                   include_dir};
  argv.insert(argv.end(), sources.begin(), sources.end());
  argv.insert(argv.end(), {"-o", library});
  return argv;
}

namespace {

// "12:5: error: text" after the file name: the line, column and message; false if not an error.
bool ParsePlace(const std::string& rest, CompilerError* error) {
  std::istringstream in(rest);
  char colon = 0;
  if (!(in >> error->line >> colon) || colon != ':' || !(in >> error->column >> colon) ||
      colon != ':') {
    return false;
  }
  std::string text;
  std::getline(in, text);
  for (const char* kind : {" error: ", " fatal error: "}) {
    if (text.rfind(kind, 0) == 0) {
      error->message = text.substr(std::string(kind).size());
      return true;
    }
  }
  return false;
}

}  // namespace

std::vector<CompilerError> ParseCompilerErrors(const std::string& output,
                                               const std::string& folder) {
  std::vector<CompilerError> errors;
  std::istringstream lines(output);
  const std::string prefix = folder.empty() || folder.back() == '/' ? folder : folder + "/";
  for (std::string line; std::getline(lines, line);) {
    // The file name ends at the first ":<digit>" (a path may hold colons, rarely).
    for (size_t at = line.find(':'); at != std::string::npos; at = line.find(':', at + 1)) {
      if (at + 1 >= line.size() || std::isdigit(static_cast<unsigned char>(line[at + 1])) == 0) {
        continue;
      }
      CompilerError error;
      if (!ParsePlace(line.substr(at + 1), &error)) break;
      error.file = line.substr(0, at);
      if (!prefix.empty() && error.file.rfind(prefix, 0) == 0) {
        error.file = error.file.substr(prefix.size());
      }
      errors.push_back(error);
      break;
    }
  }
  return errors;
}

BuildResult BuildController(const std::vector<std::string>& sources, const std::string& out_dir,
                            const std::string& name, const BuildOptions& options) {
  if (sources.empty()) throw std::runtime_error("no C++ source to build");
  std::vector<std::string> absolute_sources;
  for (const std::string& source : sources) {
    absolute_sources.push_back(fs::absolute(source).lexically_normal().string());
  }
  const std::string folder = fs::path(absolute_sources.front()).parent_path().string();
  const std::string out = fs::absolute(out_dir).lexically_normal().string();
  fs::create_directories(out);
  BuildResult result;
  result.library = out + "/" + name + ".so";
  result.log_file = out + "/" + name + ".build.log";
  fs::remove(result.library);
  fs::remove(result.log_file);
  const std::string include_dir = fs::absolute(options.include_dir).lexically_normal().string();
  std::vector<std::string> command = CompilerCommand(absolute_sources, include_dir, result.library);
  if (options.sandbox) {
    sandbox::Policy policy;
    policy.limits = options.limits;
    policy.sanitized_target = false;  // g++ is Debian's
    policy.read_only = {folder, include_dir};
    policy.read_write = {out};
    policy.chdir = folder;
    command = sandbox::Wrap(policy, command);
  }
  const auto start = std::chrono::steady_clock::now();
  Child compiler;
  compiler.Start(command, result.log_file);
  bool timed_out = false;
  while (compiler.Running()) {
    if (std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() >
        options.time_limit_s) {
      timed_out = true;
      compiler.Stop(0.2);
      break;
    }
    ::usleep(10000);
  }
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::ifstream log(result.log_file);
  std::stringstream output;
  output << log.rdbuf();
  result.errors = ParseCompilerErrors(output.str(), folder);
  if (timed_out) {
    result.problem = "the build took longer than " + core::FormatNumber(options.time_limit_s) +
                     " s and was stopped";
  } else if (!compiler.EndedCleanly()) {
    result.problem = "does not build (g++ " + compiler.HowEnded() + ")";
    if (!result.errors.empty()) {
      result.problem += ": " + result.errors.front().ToString();
      if (result.errors.size() > 1) {
        result.problem += " (and " + std::to_string(result.errors.size() - 1) + " more)";
      }
    } else {
      result.problem += ": " + compiler.LogTail(2);
    }
  } else if (!fs::is_regular_file(result.library)) {
    result.problem = "g++ ended cleanly but wrote no " + result.library;
  }
  result.built = result.problem.empty();
  return result;
}

}  // namespace sirupp::grade
