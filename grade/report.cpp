#include "grade/report.hpp"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>

#include "core/errors.hpp"
#include "core/robot_model.hpp"
#include "core/units.hpp"
#include "logger/plot.hpp"

namespace sirupp::grade {
namespace {

using Json = nlohmann::ordered_json;

Json Optional(const std::optional<double>& value) { return value ? Json(*value) : Json(nullptr); }

Json TaskJson(const TaskResult& task) {
  Json out;
  out["status"] = !task.ended.empty() ? "ended" : task.passed ? "passed" : "failed";
  if (!task.ended.empty()) {
    out["reason"] = task.ended;
    return out;
  }
  out["failed_checks"] = task.metrics.failed_checks;
  out["ticks"] = task.record.ticks();
  out["missing_rows"] = task.record.missing_rows;
  // A tracking task through sirupp-control: how closely the chip's set-point followed the path.
  if (task.record.has_reference && task.record.setpoint_deviation > 0) {
    out["setpoint_vs_path_deg"] = task.record.setpoint_deviation * 180 / kPi;
  }
  Json joints = Json::array();
  for (size_t j = 0; j < task.metrics.joints.size(); ++j) {
    const JointMetrics& m = task.metrics.joints[j];
    Json joint;
    joint["joint"] = j + 1;
    joint["moves"] = m.moves;
    joint["step"] = m.step;
    joint["rise_s"] = Optional(m.rise_s);
    joint["settling_s"] = Optional(m.settling_s);
    joint["overshoot_percent"] = Optional(m.overshoot_percent);
    joint["steady_state"] = m.steady_state;
    joint["rms_tracking"] = m.rms_tracking;
    joint["max_tracking"] = m.max_tracking;
    joint["peak_effort"] = m.peak_effort;
    joint["rms_effort"] = m.rms_effort;
    joint["saturated_s"] = m.saturated_s;
    joint["effort_rate_rms"] = m.effort_rate_rms;
    joints.push_back(joint);
  }
  out["joints"] = joints;
  return out;
}

std::string Fixed(double value, int digits) {
  std::ostringstream out;
  out.setf(std::ios::fixed);
  out.precision(digits);
  out << value;
  return out.str();
}

std::string Cell(const std::optional<double>& value, int digits, const char* none = "—") {
  return value ? Fixed(*value, digits) : none;
}

std::string Status(const TaskResult& task) {
  if (!task.ended.empty()) return "**ended**";
  return task.passed ? "pass" : "**fail**";
}

// The worst joint's position, reference and the baseline's position.
std::string Plot(const std::string& out_dir, const Task& task, const TaskResult& student,
                 const TaskResult* baseline) {
  if (!student.ended.empty() || student.record.ticks() < 2) return "";
  const auto n = static_cast<size_t>(student.record.num_joints);
  const auto j = static_cast<size_t>(student.metrics.worst_joint);
  const auto series = [&](const TaskRecord& record, const std::vector<double>& values,
                          const std::string& label, logger::PlotColor color) {
    logger::PlotSeries s;
    s.label = label;
    s.color = color;
    // At most ~2000 points: every k-th tick.
    const size_t every = std::max<size_t>(1, record.ticks() / 2000);
    for (size_t row = 0; row < record.ticks(); row += every) {
      s.x.push_back(record.time_s[row]);
      s.y.push_back(values[row * n + j] * 180 / kPi);
    }
    return s;
  };
  logger::PlotSpec spec;
  spec.title = task.name + ": joint " + std::to_string(j + 1) + " (largest RMS tracking error)";
  spec.x_label = "time (s)";
  spec.y_label = "joint " + std::to_string(j + 1) + " (deg)";
  spec.series.push_back(series(student.record, student.record.reference,
                               !student.record.has_reference ? "goal"
                               : task.track                  ? "path"
                                                             : "set-point",
                               {120, 120, 120}));
  spec.series.push_back(
      series(student.record, student.record.position, "controller", {200, 40, 40}));
  if (baseline != nullptr && baseline->ended.empty() && baseline->record.ticks() > 1) {
    spec.series.push_back(
        series(baseline->record, baseline->record.position, "baseline", {40, 80, 200}));
  }
  const std::string file = "plots/" + task.name + ".png";
  std::filesystem::create_directories(out_dir + "/plots");
  logger::WritePlot(spec, out_dir + "/" + file);
  return file;
}

void WriteFile(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
  if (!out) throw std::runtime_error("cannot write " + path);
}

}  // namespace

std::string ResultsJson(const Suite& suite, const core::RobotModel& model,
                        const ControllerResult& student, const ControllerResult* baseline) {
  Json root;
  root["format"] = "sirupp-grade-results-1";
  root["suite"] = {{"name", suite.name}, {"hash", suite.source_hash}};
  root["model"] = {{"name", model.name}, {"hash", model.source_hash}};
  root["controller"] = student.label;
  root["score"] = student.score();
  root["passed"] = student.passed();
  root["tasks_total"] = student.tasks.size();
  if (baseline != nullptr) {
    root["baseline"] = baseline->label;
    root["baseline_score"] = baseline->score();
    root["baseline_passed"] = baseline->passed();
  }
  Json tasks = Json::array();
  for (size_t t = 0; t < suite.tasks.size(); ++t) {
    Json task;
    task["name"] = suite.tasks[t].name;
    task["what"] = suite.tasks[t].description;
    task["controller"] = TaskJson(student.tasks[t]);
    if (baseline != nullptr) task["baseline"] = TaskJson(baseline->tasks[t]);
    tasks.push_back(task);
  }
  root["tasks"] = tasks;
  return root.dump(2) + "\n";
}

std::string WriteReport(const std::string& out_dir, const Suite& suite,
                        const core::RobotModel& model, const ControllerResult& student,
                        const ControllerResult* baseline) {
  std::filesystem::create_directories(out_dir);
  const std::string json = ResultsJson(suite, model, student, baseline);
  WriteFile(out_dir + "/results.json", json);
  const std::string hash = core::Fnv1aHex(json);

  std::ostringstream md;
  md << "# Grade: " << student.label << "\n\n";
  md << "Suite **" << suite.name << "** (" << suite.file << ", hash " << suite.source_hash
     << "), model " << model.name << ". " << suite.description << "\n\n";
  md << "| | tasks passed | score |\n|---|---|---|\n";
  md << "| " << student.label << " | " << student.passed() << "/" << student.tasks.size() << " | "
     << Fixed(student.score(), 1) << " |\n";
  if (baseline != nullptr) {
    md << "| " << baseline->label << " | " << baseline->passed() << "/" << baseline->tasks.size()
       << " | " << Fixed(baseline->score(), 1) << " |\n";
  }
  md << "\nDeterministic: every task ran in lockstep; `results.json` has FNV-1a hash `" << hash
     << "`. The same controller gives the same hash on every run (and for any `-j`).\n\n";
  md << "Columns: rise (10–90 %) and settling time (2 % band, at least 0.1°) in s, overshoot in %, "
        "steady-state error (last 0.1 s), RMS and max tracking error in deg; peak and RMS effort "
        "in N·m, time saturated in s, smoothness = RMS effort rate in N·m/s. Each cell is "
        "controller / baseline. — : not reached or not applicable.\n";
  for (size_t t = 0; t < suite.tasks.size(); ++t) {
    const Task& task = suite.tasks[t];
    const TaskResult& s = student.tasks[t];
    const TaskResult* b = baseline != nullptr ? &baseline->tasks[t] : nullptr;
    md << "\n## " << task.name << ": " << Status(s);
    if (b != nullptr) md << " (baseline: " << Status(*b) << ")";
    md << "\n\n"
       << task.description << "; " << core::FormatNumber(task.duration_s) << " s (suite line "
       << task.line << ").\n\n";
    if (!s.ended.empty()) md << "Ended early: " << s.ended << "\n\n";
    for (const std::string& check : s.metrics.failed_checks) md << "- failed: " << check << "\n";
    if (!s.metrics.failed_checks.empty()) md << "\n";
    if (b != nullptr && !b->ended.empty()) md << "Baseline ended early: " << b->ended << "\n\n";
    if (!s.ended.empty() && (b == nullptr || !b->ended.empty())) continue;
    md << "| joint | rise | settling | overshoot | steady | RMS track | max track | peak u | RMS u "
          "| saturated | du/dt RMS |\n|---|---|---|---|---|---|---|---|---|---|---|\n";
    const size_t n = static_cast<size_t>(model.num_joints());
    for (size_t j = 0; j < n; ++j) {
      const auto pair = [&](auto get) {
        const std::string left = s.ended.empty() ? get(s.metrics.joints[j]) : "—";
        const std::string right =
            b != nullptr && b->ended.empty() ? get(b->metrics.joints[j]) : "—";
        return left + " / " + right;
      };
      md << "| " << j + 1 << (s.ended.empty() && s.metrics.joints[j].moves ? " (moves)" : "")
         << " | " << pair([](const JointMetrics& m) { return m.moves ? Cell(m.rise_s, 3) : "—"; })
         << " | " << pair([](const JointMetrics& m) {
              return m.moves ? Cell(m.settling_s, 3, "never") : "—";
            })
         << " | "
         << pair([](const JointMetrics& m) { return m.moves ? Cell(m.overshoot_percent, 1) : "—"; })
         << " | " << pair([](const JointMetrics& m) { return Fixed(m.steady_state, 3); }) << " | "
         << pair([](const JointMetrics& m) { return Fixed(m.rms_tracking, 3); }) << " | "
         << pair([](const JointMetrics& m) { return Fixed(m.max_tracking, 3); }) << " | "
         << pair([](const JointMetrics& m) { return Fixed(m.peak_effort, 2); }) << " | "
         << pair([](const JointMetrics& m) { return Fixed(m.rms_effort, 2); }) << " | "
         << pair([](const JointMetrics& m) { return Fixed(m.saturated_s, 3); }) << " | "
         << pair([](const JointMetrics& m) { return Fixed(m.effort_rate_rms, 0); }) << " |\n";
    }
    const std::string plot = Plot(out_dir, task, s, b);
    if (!plot.empty()) md << "\n![" << task.name << "](" << plot << ")\n";
  }
  WriteFile(out_dir + "/report.md", md.str());
  return hash;
}

std::string SummaryLine(const Suite& suite, const ControllerResult& student,
                        const ControllerResult* baseline, const std::string& hash) {
  std::ostringstream out;
  out << "grade: " << student.label << " on " << suite.name << ": " << student.passed() << "/"
      << student.tasks.size() << " tasks passed, score " << Fixed(student.score(), 1);
  if (baseline != nullptr) {
    out << " (baseline " << baseline->passed() << "/" << baseline->tasks.size() << ", "
        << Fixed(baseline->score(), 1) << ")";
  }
  out << "; results fnv1a " << hash;
  return out.str();
}

void WriteClassTable(const std::string& out_dir, const Suite& suite,
                     const std::vector<Submission>& submissions, const ControllerResult* baseline) {
  std::filesystem::create_directories(out_dir);
  const auto csv_field = [](const std::string& text) {
    std::string quoted = "\"";
    for (char c : text) quoted += c == '"' ? std::string("\"\"") : std::string(1, c);
    return quoted + "\"";
  };
  std::ostringstream csv, md;
  csv << "submission,score,passed,tasks,failed_tasks,problem\n";
  md << "# Class table: suite " << suite.name
     << "\n\n| submission | score | passed | failed tasks "
        "| problem |\n|---|---|---|---|---|\n";
  const auto row = [&](const std::string& name, const ControllerResult& result,
                       const std::string& problem) {
    std::string failed;
    for (const std::string& task : result.FailedTasks())
      failed += (failed.empty() ? "" : " ") + task;
    const std::string score = problem.empty() ? Fixed(result.score(), 1) : "";
    const std::string passed = problem.empty() ? std::to_string(result.passed()) : "";
    csv << csv_field(name) << "," << score << "," << passed << "," << suite.tasks.size() << ","
        << csv_field(problem.empty() ? failed : "") << "," << csv_field(problem) << "\n";
    std::string md_problem = problem;
    for (char& c : md_problem) {
      if (c == '|' || c == '\n') c = ' ';
    }
    md << "| " << name << " | " << (problem.empty() ? score : "—") << " | "
       << (problem.empty() ? passed + "/" + std::to_string(suite.tasks.size()) : "—") << " | "
       << (problem.empty() ? failed : "") << " | " << md_problem << " |\n";
  };
  if (baseline != nullptr) row("(baseline PIC-SERVO PID)", *baseline, "");
  for (const Submission& submission : submissions) {
    row(submission.name, submission.result, submission.problem);
  }
  WriteFile(out_dir + "/class.csv", csv.str());
  WriteFile(out_dir + "/class.md", md.str());
}

}  // namespace sirupp::grade
