#include "grade/notebook_assignment.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "core/errors.hpp"
#include "grade/child.hpp"
#include "runtime/data_path.hpp"
#include "sandbox/sandbox.hpp"

namespace sirupp::grade {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::ordered_json;

constexpr size_t kMaxResultBytes = 16 * 1024 * 1024;
constexpr size_t kMaxTestsBytes = 1024 * 1024;

std::string Num(double value) { return core::FormatNumber(value); }

std::string ReadAll(const std::string& file, size_t limit, bool* too_large) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw std::runtime_error(file + ": cannot be read");
  std::string text;
  text.resize(limit + 1);
  in.read(text.data(), static_cast<std::streamsize>(text.size()));
  text.resize(static_cast<size_t>(in.gcount()));
  *too_large = text.size() > limit;
  if (*too_large) text.resize(limit);
  return text;
}

// Every hidden test at 0 with `why` (the notebook never reached them).
void NotRun(const std::vector<NotebookTest>& tests, const std::string& why,
            NotebookResult& result) {
  result.tests.clear();
  for (const NotebookTest& test : tests) {
    NotebookTestResult scored;
    scored.name = test.name;
    scored.max_points = test.points;
    scored.message = "not run: " + why;
    result.tests.push_back(scored);
  }
}

// json[key] when `json` is an object holding it, else nullptr.
const nlohmann::json* Field(const nlohmann::json& json, const char* key) {
  if (!json.is_object()) return nullptr;
  const auto found = json.find(key);
  return found == json.end() ? nullptr : &*found;
}

std::string JsonString(const nlohmann::json& json, const char* key) {
  const nlohmann::json* value = Field(json, key);
  return value != nullptr && value->is_string() ? value->get<std::string>() : "";
}

bool JsonBool(const nlohmann::json& json, const char* key) {
  const nlohmann::json* value = Field(json, key);
  return value != nullptr && value->is_boolean() && value->get<bool>();
}

double JsonNumber(const nlohmann::json& json, const char* key) {
  const nlohmann::json* value = Field(json, key);
  return value != nullptr && value->is_number() ? value->get<double>() : 0.0;
}

int JsonInt(const nlohmann::json& json, const char* key) {
  const nlohmann::json* value = Field(json, key);
  return value != nullptr && value->is_number_integer() ? value->get<int>() : 0;
}

// json[key] when it is a list, else an empty one.
const nlohmann::json& JsonList(const nlohmann::json& json, const char* key) {
  static const nlohmann::json kEmpty = nlohmann::json::array();
  const nlohmann::json* value = Field(json, key);
  return value != nullptr && value->is_array() ? *value : kEmpty;
}

}  // namespace

double NotebookResult::score() const {
  double sum = 0;
  for (const NotebookTestResult& test : tests) sum += test.points;
  return sum;
}

double NotebookResult::max_score() const {
  double sum = 0;
  for (const NotebookTestResult& test : tests) sum += test.max_points;
  return sum;
}

std::vector<NotebookTest> ReadNotebookTests(const std::string& tests_file) {
  bool too_large = false;
  const std::string text = ReadAll(tests_file, kMaxTestsBytes, &too_large);
  if (too_large) throw std::runtime_error(tests_file + ": larger than 1 MiB");
  static const std::regex def_line(R"(^def\s+(test_[A-Za-z0-9_]*)\s*\()");
  static const std::regex points_line(R"(^@points\(\s*([^)]*)\)\s*(#.*)?$)");
  std::vector<NotebookTest> tests;
  std::istringstream lines(text);
  std::string line;
  int number = 0;
  double pending = 1;
  int pending_line = 0;
  while (std::getline(lines, line)) {
    ++number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    std::smatch match;
    if (std::regex_search(line, match, points_line)) {
      const std::string value = match[1].str();
      char* end = nullptr;
      const double points = std::strtod(value.c_str(), &end);
      if (value.empty() || end == value.c_str() || *end != '\0' || !std::isfinite(points) ||
          points <= 0) {
        throw std::runtime_error(tests_file + ":" + std::to_string(number) + ": @points(" + value +
                                 "): the points must be a number > 0");
      }
      pending = points;
      pending_line = number;
    } else if (std::regex_search(line, match, def_line)) {
      for (const NotebookTest& test : tests) {
        if (test.name == match[1].str()) {
          throw std::runtime_error(tests_file + ":" + std::to_string(number) + ": " + test.name +
                                   " is defined twice (only the last would run)");
        }
      }
      tests.push_back({match[1].str(), pending});
      pending = 1;
      pending_line = 0;
    } else if (pending_line != 0 && !line.empty() && line[0] != '@' && line[0] != '#') {
      throw std::runtime_error(tests_file + ":" + std::to_string(pending_line) +
                               ": @points(...) must be right above a def test_NAME(...)");
    }
  }
  if (tests.empty()) {
    throw std::runtime_error(tests_file + ": no test: the hidden tests are top-level functions " +
                             "named test_* (docs/notebook-assignments.md)");
  }
  return tests;
}

std::string HiddenTestsExposed(const std::string& tests_file, const std::string& bin_dir) {
  const fs::path file = fs::weakly_canonical(fs::absolute(tests_file)).lexically_normal();
  const auto under = [&file](const fs::path& folder) {
    const fs::path relative =
        file.lexically_relative(fs::weakly_canonical(folder).lexically_normal());
    return !relative.empty() && *relative.begin() != "..";
  };
  if (under("/usr")) {
    return file.string() +
           " is under /usr, which every student's sandbox reads (the grader's and "
           "the notebook servers'): keep the hidden tests elsewhere, e.g. beside "
           "the class file";
  }
  if (!bin_dir.empty() && under(fs::path(bin_dir) / ".." / "python")) {
    return file.string() + " is in the Python module's folder, which the grader's sandbox reads";
  }
  const std::string robots = runtime::ResolveDataPath("config/robots");
  if (fs::is_directory(robots) && under(robots)) {
    return file.string() + " is among the robot models, which the grader's sandbox reads";
  }
  return "";
}

NotebookResult GradeNotebook(const std::string& notebook, const std::string& tests_file,
                             const NotebookGradeOptions& options) {
  const std::vector<NotebookTest> tests = ReadNotebookTests(tests_file);
  NotebookResult result;
  const fs::path work = fs::absolute(options.work_dir);
  const fs::path scratch = work / "scratch";
  std::error_code ignored;
  fs::remove_all(scratch, ignored);
  fs::create_directories(scratch);
  fs::permissions(work, fs::perms::owner_all | fs::perms::group_read | fs::perms::group_exec |
                            fs::perms::others_read | fs::perms::others_exec);
  // The copy the code runs on (mode 644 in a 777 folder: the sandbox's uid, as root, owns it).
  bool too_large = false;
  std::string text;
  try {
    text = ReadAll(notebook, options.max_notebook_bytes, &too_large);
  } catch (const std::runtime_error& error) {
    NotRun(tests, error.what(), result);
    result.problem = error.what();
    return result;
  }
  if (too_large) {
    result.problem =
        "the notebook is larger than " + std::to_string(options.max_notebook_bytes / 1024) + " KiB";
    NotRun(tests, result.problem, result);
    return result;
  }
  const fs::path copy = scratch / "submission.ipynb";
  {
    std::ofstream out(copy, std::ios::binary);
    out << text;
    if (!out) throw std::runtime_error(copy.string() + ": cannot be written");
  }
  const fs::path module_dir = fs::weakly_canonical(fs::path(options.bin_dir) / ".." / "python");
  const std::string host = (module_dir / "sirupp" / "notebook_grade_host.py").string();
  if (!fs::is_regular_file(host)) {
    result.problem = "the notebook grader " + host + " is missing (build sirupp_python_module)";
    NotRun(tests, result.problem, result);
    return result;
  }
  std::vector<std::string> argv = {"/usr/bin/python3",
                                   "-I",
                                   host,
                                   copy.string(),
                                   Num(options.timeout_s),
                                   std::to_string(options.output_limit_bytes)};
  if (options.sandbox) {
    sandbox::Policy policy;
    policy.limits.cpu_s = options.timeout_s + 10;
    policy.limits.memory_mb = static_cast<uint64_t>(options.memory_mb);
    policy.limits.processes = 64;  // threads count: the kernel's and nbclient's, numpy's
    policy.limits.file_size_mb = 64;
    policy.read_only = {module_dir.string()};
    // sirupp.data_path("config/...") in a notebook: the robot models, read-only.
    const std::string config = runtime::ResolveDataPath("config/robots");
    if (fs::is_directory(config)) policy.read_only.push_back(fs::weakly_canonical(config).string());
    policy.read_write = {scratch.string()};
    policy.chdir = scratch.string();
    try {
      argv = sandbox::Wrap(policy, argv);
    } catch (const std::runtime_error& error) {
      result.problem = std::string("the sandbox cannot be had on this machine: ") + error.what() +
                       " (docs/sandbox.md); the notebook was not run";
      NotRun(tests, result.problem, result);
      return result;
    }
  }
  // The tests on stdin and the result on stdout, both opened here, outside the sandbox: neither is
  // a path the notebook's code can reach.
  const fs::path result_file = work / "result-host.json";
  fs::remove(result_file, ignored);
  std::vector<std::string> command = {
      "/bin/sh",
      "-c",
      "tests=$1; result=$2; shift 2; exec \"$@\" <\"$tests\" >\"$result\"",
      "sh",
      fs::absolute(tests_file).string(),
      result_file.string()};
  command.insert(command.end(), argv.begin(), argv.end());
  const std::string log = (work / "grade.log").string();
  fs::remove(log, ignored);
  Child child;
  try {
    child.Start(command, log);
  } catch (const std::exception& error) {
    result.problem = std::string("the grader could not start: ") + error.what();
    NotRun(tests, result.problem, result);
    return result;
  }
  // The host stops a cell at timeout_s itself; this is for a host that cannot (a kernel that
  // will not start, the whole sandbox stuck).
  const auto deadline =
      std::chrono::steady_clock::now() + std::chrono::duration<double>(options.timeout_s + 20);
  while (child.Running()) {
    if (std::chrono::steady_clock::now() > deadline) {
      child.Stop(1.0);
      result.problem = "the notebook did not finish within " + Num(options.timeout_s) +
                       " s (the grader was stopped)";
      NotRun(tests, result.problem, result);
      return result;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  std::string host_text;
  try {
    host_text = ReadAll(result_file.string(), kMaxResultBytes, &too_large);
  } catch (const std::runtime_error&) {
    host_text.clear();
  }
  nlohmann::json host_json;
  if (!host_text.empty() && !too_large) {
    host_json = nlohmann::json::parse(host_text, nullptr, false);
  }
  if (!host_json.is_object() || JsonString(host_json, "format") != kNotebookResultFormat) {
    const std::string tail = child.LogTail(3);
    result.problem = "the grader ended (" + child.HowEnded() + ") without a result" +
                     (tail.empty() ? std::string() : ": " + tail);
    if (child.HowEnded().find("SIGKILL") != std::string::npos ||
        child.HowEnded().find("SIGXCPU") != std::string::npos) {
      result.problem += " (the CPU or memory limit: " + std::to_string(options.memory_mb) + " MB)";
    }
    NotRun(tests, result.problem, result);
    return result;
  }
  result.problem = JsonString(host_json, "problem");
  result.output = JsonString(host_json, "output");
  result.cells = JsonInt(host_json, "cells");
  for (const auto& error : JsonList(host_json, "cell_errors")) {
    if (JsonInt(error, "cell") > 0) {
      result.cell_errors.push_back({JsonInt(error, "cell"), JsonString(error, "error")});
    }
  }
  // Scores for the tests the file names, whatever the kernel said of others.
  std::map<std::string, nlohmann::json> reported;
  for (const auto& test : JsonList(host_json, "tests")) {
    if (test.is_object()) reported[JsonString(test, "name")] = test;
  }
  if (!result.problem.empty() && reported.empty()) {
    NotRun(tests, result.problem, result);
    return result;
  }
  for (const NotebookTest& test : tests) {
    NotebookTestResult scored;
    scored.name = test.name;
    scored.max_points = test.points;
    auto found = reported.find(test.name);
    if (found == reported.end()) {
      scored.message = "not run: the test was not found after the notebook ran (the notebook " +
                       std::string("replaced it?)");
    } else {
      const nlohmann::json& got = found->second;
      scored.passed = JsonBool(got, "passed");
      scored.points = scored.passed ? test.points : 0;
      scored.message = scored.passed ? "" : JsonString(got, "message").substr(0, 300);
    }
    result.tests.push_back(scored);
  }
  return result;
}

Json NotebookResultJson(const NotebookResult& result) {
  Json json;
  json["format"] = kNotebookResultFormat;
  json["score"] = result.score();
  json["max_score"] = result.max_score();
  json["tests"] = Json::array();
  for (const NotebookTestResult& test : result.tests) {
    json["tests"].push_back({{"name", test.name},
                             {"points", test.points},
                             {"max_points", test.max_points},
                             {"passed", test.passed},
                             {"message", test.message}});
  }
  json["cells"] = result.cells;
  json["cell_errors"] = Json::array();
  for (const NotebookCellError& error : result.cell_errors) {
    json["cell_errors"].push_back({{"cell", error.cell}, {"error", error.error}});
  }
  json["problem"] = result.problem;
  json["output"] = result.output;
  return json;
}

NotebookResult NotebookResultFromJson(const nlohmann::json& json) {
  if (!json.is_object() || JsonString(json, "format") != kNotebookResultFormat) {
    throw std::runtime_error(std::string("format: not ") + kNotebookResultFormat);
  }
  NotebookResult result;
  const nlohmann::json* tests = Field(json, "tests");
  if (tests == nullptr || !tests->is_array())
    throw std::runtime_error("tests: missing or not a list");
  for (const auto& test : *tests) {
    if (!test.is_object()) throw std::runtime_error("tests: an entry is not an object");
    NotebookTestResult scored;
    scored.name = JsonString(test, "name");
    scored.passed = JsonBool(test, "passed");
    scored.points = JsonNumber(test, "points");
    scored.max_points = JsonNumber(test, "max_points");
    scored.message = JsonString(test, "message");
    result.tests.push_back(scored);
  }
  result.cells = JsonInt(json, "cells");
  for (const auto& error : JsonList(json, "cell_errors")) {
    result.cell_errors.push_back({JsonInt(error, "cell"), JsonString(error, "error")});
  }
  result.problem = JsonString(json, "problem");
  result.output = JsonString(json, "output");
  return result;
}

std::string NotebookResultTable(const NotebookResult& result) {
  size_t width = 4;
  for (const NotebookTestResult& test : result.tests) width = std::max(width, test.name.size());
  std::ostringstream out;
  char line[64];
  out << "test" << std::string(width - 4, ' ') << "  points  result\n";
  for (const NotebookTestResult& test : result.tests) {
    std::snprintf(line, sizeof line, "%6s",
                  (Num(test.points) + "/" + Num(test.max_points)).c_str());
    out << test.name << std::string(width - test.name.size(), ' ') << "  " << line << "  "
        << (test.passed ? "pass" : "FAIL: " + test.message) << "\n";
  }
  std::snprintf(line, sizeof line, "%6s",
                (Num(result.score()) + "/" + Num(result.max_score())).c_str());
  out << "total" << std::string(width > 5 ? width - 5 : 0, ' ') << "  " << line << "\n";
  for (const NotebookCellError& error : result.cell_errors) {
    out << "code cell " << error.cell << " raised " << error.error << "\n";
  }
  if (!result.problem.empty()) out << "problem: " << result.problem << "\n";
  return out.str();
}

}  // namespace sirupp::grade
