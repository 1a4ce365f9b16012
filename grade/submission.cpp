#include "grade/submission.hpp"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <vector>

#include "grade/build_controller.hpp"

namespace sirupp::grade {
namespace fs = std::filesystem;

namespace {

std::vector<fs::path> FilesEnding(const fs::path& folder, const std::string& ending) {
  std::vector<fs::path> files;
  for (const fs::directory_entry& entry : fs::directory_iterator(folder)) {
    const std::string name = entry.path().filename().string();
    if (entry.is_regular_file() && name.size() > ending.size() &&
        name.compare(name.size() - ending.size(), ending.size(), ending) == 0) {
      files.push_back(entry.path());
    }
  }
  std::sort(files.begin(), files.end());
  return files;
}

std::string FirstLine(const fs::path& file) {
  std::ifstream in(file);
  std::string line;
  std::getline(in, line);
  while (!line.empty() && (line.back() == '\r' || line.back() == ' ')) line.pop_back();
  return line;
}

}  // namespace

FoundController FindSubmission(const std::string& folder, const std::string& include_dir,
                               const std::string& build_dir, bool sandbox) {
  FoundController found;
  found.spec.sandbox = sandbox;
  const fs::path dir = fs::absolute(folder);
  const std::string name = dir.filename().string();
  if (fs::exists(dir / "command")) {
    std::istringstream words(FirstLine(dir / "command"));
    found.spec.kind = ControllerSpec::Kind::kProcess;
    for (std::string word; words >> word;) {
      found.spec.command.push_back(word.rfind("./", 0) == 0 ? (dir / word.substr(2)).string()
                                                            : word);
    }
    if (found.spec.command.empty()) found.problem = "the file 'command' is empty";
    found.spec.label = name;
    return found;
  }
  found.spec.kind = ControllerSpec::Kind::kLibrary;
  found.spec.label = name;
  if (fs::exists(dir / "args")) found.spec.args = FirstLine(dir / "args");
  const std::vector<fs::path> libraries = FilesEnding(dir, ".so");
  if (!libraries.empty()) {
    found.spec.library = libraries.front().string();
    return found;
  }
  // A controller written in Python runs in sirupp-control like a library (its host program is
  // chosen by the file's name: control/isolated_law.hpp).
  const std::vector<fs::path> python = FilesEnding(dir, ".py");
  if (!python.empty()) {
    found.spec.library = python.front().string();
    return found;
  }
  const std::vector<fs::path> sources = FilesEnding(dir, ".cpp");
  if (sources.empty()) {
    found.problem =
        "no controller: expected a file 'command', a library (*.so), a Python controller (*.py) "
        "or sources (*.cpp)";
    return found;
  }
  std::vector<std::string> source_names;
  for (const fs::path& source : sources) source_names.push_back(source.string());
  BuildOptions options;
  options.include_dir = include_dir;
  options.sandbox = sandbox;
  BuildResult built;
  try {
    built = BuildController(source_names, (fs::absolute(build_dir) / name).string(), name, options);
  } catch (const std::runtime_error& error) {
    found.problem = std::string("cannot be built: ") + error.what();
    return found;
  }
  if (!built.built) {
    found.problem = built.problem;
    return found;
  }
  found.spec.library = built.library;
  return found;
}

}  // namespace sirupp::grade
