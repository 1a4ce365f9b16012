#include "grade/grade.hpp"

#include <unistd.h>

#include <atomic>
#include <filesystem>
#include <mutex>
#include <regex>
#include <thread>

#include "grade/port_lease.hpp"

namespace sirupp::grade {

const char* const kBaselineLabel =
    "baseline: PIC-SERVO PID (the model's gains: Kp 100, Kd 1000, Ki 0)";

int ControllerResult::passed() const {
  int count = 0;
  for (const TaskResult& task : tasks) count += task.passed ? 1 : 0;
  return count;
}

double ControllerResult::score() const {
  return tasks.empty() ? 0 : 100.0 * passed() / static_cast<double>(tasks.size());
}

std::vector<std::string> ControllerResult::FailedTasks() const {
  std::vector<std::string> names;
  for (const TaskResult& task : tasks) {
    if (!task.passed) names.push_back(task.task);
  }
  return names;
}

namespace {

// A library that does not load fails every task the same way, however many ran before the first
// failure was seen (the same results for any -j): every task of each controller marked in
// `load_failed` gets the reason of its first such task.
void MarkUnloadable(const Suite& suite, const std::vector<char>& load_failed,
                    std::vector<ControllerResult>& results) {
  for (size_t c = 0; c < load_failed.size(); ++c) {
    if (load_failed[c] == 0) continue;
    std::string reason;
    for (const TaskResult& task : results[c].tasks) {
      if (reason.empty() && task.ended.rfind("sirupp-control ended (exit code 2)", 0) == 0) {
        reason = task.ended;
      }
    }
    for (TaskResult& task : results[c].tasks) {
      task = TaskResult{};
      task.task = suite.tasks[static_cast<size_t>(&task - results[c].tasks.data())].name;
      task.ended = "the controller could not be loaded: " + reason;
    }
  }
}

}  // namespace

std::vector<ControllerResult> RunControllers(const Suite& suite, const core::RobotModel& model,
                                             const std::vector<ControllerSpec>& controllers,
                                             const GradeOptions& options) {
  struct Job {
    size_t controller, task;
  };
  std::vector<Job> jobs;
  std::vector<ControllerResult> results(controllers.size());
  for (size_t c = 0; c < controllers.size(); ++c) {
    results[c].label = controllers[c].label;
    results[c].tasks.resize(suite.tasks.size());
    for (size_t t = 0; t < suite.tasks.size(); ++t) {
      results[c].tasks[t].task = suite.tasks[t].name;
      jobs.push_back({c, t});
    }
  }
  // Ports from a lease (grade/port_lease.hpp): no two tasks of any graders on this machine share
  // one. Each process starts its search elsewhere in the range, so few locks are tried.
  const int port_base = options.port_base > 0 ? options.port_base : kPortBase;
  const int port_offset = static_cast<int>(::getpid() % 97) * 100;
  std::atomic<size_t> next{0};
  std::mutex mutex;
  std::vector<char> load_failed(controllers.size(), 0);
  const auto worker = [&] {
    for (size_t i = next++; i < jobs.size(); i = next++) {
      const Job job = jobs[i];
      const Task& task = suite.tasks[job.task];
      TaskResult& result = results[job.controller].tasks[job.task];
      {
        const std::lock_guard<std::mutex> lock(mutex);
        if (load_failed[job.controller] != 0) {
          result.ended = "not run: the controller could not be loaded";
          continue;
        }
      }
      RunOptions run;
      run.bin_dir = options.bin_dir;
      run.work_dir = options.work_dir + "/" + std::to_string(job.controller) + "_" + task.name;
      std::filesystem::create_directories(run.work_dir);
      // Its own port for each job (and each grader process): no task hears another.
      PortLease lease;
      try {
        lease = PortLease::Acquire(port_base, kPortCount, port_offset + static_cast<int>(i),
                                   options.port_lock_dir);
      } catch (const std::exception& error) {
        result.ended = error.what();
        continue;
      }
      // A receive buffer that holds a whole tracking plan (up to 256 KiB, ~190 datagrams of
      // LCM's 1.4 KB fragments) even when sirupp-control is slow to read: the kernel's default
      // (208 KiB of buffer, counted with each datagram's overhead) lost a 164 KB ARM_PLAN on a
      // loaded machine. The kernel caps it at net.core.rmem_max.
      run.port = lease.port();
      TaskRecord record = RunTask(suite, model, task, controllers[job.controller], run);
      lease.Release();
      if (!record.completed) {
        // Process ids differ from run to run; the reason must not.
        static const std::regex pid(R"(process \d+)");
        result.ended = std::regex_replace(record.failure, pid, "process");
        if (controllers[job.controller].kind == ControllerSpec::Kind::kLibrary &&
            record.failure.rfind("sirupp-control ended (exit code 2)", 0) == 0) {
          const std::lock_guard<std::mutex> lock(mutex);
          load_failed[job.controller] = 1;
        }
        continue;
      }
      result.metrics = ComputeMetrics(model, record, task.pass);
      result.passed = result.metrics.passed();
      result.record = std::move(record);
    }
  };
  const int count = std::max(1, std::min<int>(options.jobs, static_cast<int>(jobs.size())));
  std::vector<std::thread> threads;
  for (int k = 1; k < count; ++k) threads.emplace_back(worker);
  worker();
  for (std::thread& thread : threads) thread.join();
  MarkUnloadable(suite, load_failed, results);
  return results;
}

}  // namespace sirupp::grade
