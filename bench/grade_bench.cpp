// bench_grade: how fast `sirupp grade` runs tasks, and the speed-up from 1 to N parallel jobs.
// Grades the baseline (PIC-SERVO PID) on a suite with -j 1, then -j N, and prints tasks per second
// for each and the ratio; also checks the two runs gave the same results.json bytes.
//   bench_grade [SUITE (config/grading/basic.yaml)] [N (2)]
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <iostream>

#include "core/model_loader.hpp"
#include "grade/grade.hpp"
#include "grade/report.hpp"
#include "runtime/data_path.hpp"
#include "tools/cli.hpp"

namespace {
std::string Resolve(const std::string& path) { return sirupp::runtime::ResolveDataPath(path); }
}  // namespace

int main(int argc, char** argv) {
  const std::string suite_file = argc > 1 ? argv[1] : "config/grading/basic.yaml";
  const int jobs = argc > 2 ? std::atoi(argv[2]) : 2;
  const sirupp::grade::Suite suite = sirupp::grade::LoadSuite(Resolve(suite_file), &Resolve);
  const sirupp::core::RobotModel model = sirupp::core::LoadRobotModel(suite.model_file);
  sirupp::grade::ControllerSpec baseline;
  baseline.label = sirupp::grade::kBaselineLabel;
  sirupp::grade::GradeOptions options;
  options.bin_dir = std::filesystem::read_symlink("/proc/self/exe").parent_path().string();
  options.work_dir = std::filesystem::temp_directory_path() / "bench_grade";
  std::string first_json;
  double first_rate = 0;
  for (int j : {1, jobs}) {
    options.jobs = j;
    const auto start = std::chrono::steady_clock::now();
    const auto results = sirupp::grade::RunControllers(suite, model, {baseline}, options);
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    const double rate = static_cast<double>(suite.tasks.size()) / seconds;
    const std::string json = sirupp::grade::ResultsJson(suite, model, results[0], nullptr);
    std::cout << "bench_grade: " << suite.name << ", " << suite.tasks.size() << " tasks, -j " << j
              << ": " << seconds << " s, " << rate << " tasks/s";
    if (j == 1) {
      first_rate = rate;
      first_json = json;
    } else {
      std::cout << ", speed-up " << rate / first_rate << "x, results "
                << (json == first_json ? "identical" : "DIFFERENT");
    }
    std::cout << "\n";
  }
  return 0;
}
