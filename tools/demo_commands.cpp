#include "tools/demo_commands.hpp"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <ostream>
#include <sirupp/hardware_status_t.hpp>
#include <sstream>

#include "client/client.hpp"
#include "core/bus.hpp"
#include "core/channels.hpp"
#include "core/errors.hpp"
#include "core/model_loader.hpp"
#include "core/model_report.hpp"
#include "lab/experiment.hpp"
#include "launch/layout.hpp"
#include "launch/supervisor.hpp"
#include "logger/report.hpp"
#include "runtime/args.hpp"
#include "runtime/data_path.hpp"
#include "runtime/process_main.hpp"
#include "tools/cli.hpp"
#include "tools/control_commands.hpp"
#include "tools/lab_commands.hpp"
#include "tools/launch_commands.hpp"
#include "tools/report_commands.hpp"
#include "tools/rig_args.hpp"

namespace sirupp::tools {

namespace fs = std::filesystem;

const char* const kDemoAbout =
    "The main job: the SIRUPP paper's experiment, headless. Starts the processes of --layout\n"
    "(default config/labs/demo.yaml: sirupp-picservo-emu, sirupp-sim, sirupp-control,\n"
    "sirupp-hardware linked to the emulated arm, sirupp-logger, sirupp-viewer), runs the movement\n"
    "sets (config/plans/setN.plan; --sets 1 7 or I VII, default all seven) on the virtual and\n"
    "the emulated real arm, stops "
    "the processes and writes the Table II report. Everything goes to --out (default\n"
    "results/demo-YYYYmmdd-HHMMSS): data/ (the logger's files), report/ (report.md, CSV tables,\n"
    "plots), images/ and video/ (the viewer), logs/ (each process's output).\n"
    "  --lcm-url URL   the bus (default: a private udpm port with ttl=0, so a lab's traffic and\n"
    "                  other demos never mix)\n"
    "  --model M2      the virtual arm's model (e.g. one `sirupp identify` wrote) for\n"
    "                  sirupp-sim, sirupp-control, sirupp-hardware and sirupp-logger; the\n"
    "                  emulated real arm keeps its own. Then `sirupp report RUN2/data --compare\n"
    "                  RUN1/data` puts both runs' virtual-vs-real errors side by side.\n"
    "Exit: 0 every set ran and every process stopped cleanly, 1 otherwise, 2 bad arguments.\n";

namespace {

using Clock = std::chrono::steady_clock;

double Since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

std::string Rounded(double value, int digits) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(digits) << value;
  return s.str();
}

// The first comment line of a plan file, without "# ": what the set does.
std::string PlanTitle(const std::string& file) {
  std::ifstream in(file);
  std::string line;
  if (std::getline(in, line) && line.rfind("# ", 0) == 0) {
    // "Movement set I (SIRUPP paper, Table II): j1 from 0 to 90 degrees." -> after the colon
    const size_t colon = line.find("): ");
    return colon == std::string::npos ? line.substr(2) : line.substr(colon + 3);
  }
  return fs::path(file).filename().string();
}

std::string Size(uintmax_t bytes) {
  if (bytes >= 10 * 1024 * 1024) return std::to_string(bytes / (1024 * 1024)) + " MiB";
  if (bytes >= 10 * 1024) return std::to_string(bytes / 1024) + " KiB";
  return std::to_string(bytes) + " B";
}

// What the results folder holds, one line per file (folders with many files summarised).
void ListResults(const fs::path& dir, std::ostream& out) {
  std::vector<fs::path> folders = {dir};
  for (const auto& e : fs::directory_iterator(dir)) {
    if (e.is_directory()) folders.push_back(e.path());
  }
  std::sort(folders.begin() + 1, folders.end());
  for (const fs::path& folder : folders) {
    std::vector<fs::directory_entry> files;
    for (const auto& e : fs::directory_iterator(folder)) {
      if (e.is_regular_file()) files.push_back(e);
    }
    std::sort(files.begin(), files.end(),
              [](const auto& a, const auto& b) { return a.path() < b.path(); });
    const std::string rel = folder == dir ? "" : fs::relative(folder, dir).string() + "/";
    if (files.size() > 8) {
      uintmax_t total = 0;
      for (const auto& f : files) total += f.file_size();
      out << "  " << std::left << std::setw(40)
          << rel + files.front().path().filename().string() + " .. " +
                 files.back().path().filename().string()
          << std::right << " " << files.size() << " files, " << Size(total) << "\n";
      continue;
    }
    for (const auto& f : files) {
      out << "  " << std::left << std::setw(40) << rel + f.path().filename().string() << std::right
          << " " << Size(f.file_size()) << "\n";
    }
  }
}

// Waits until the bridge reports the emulated arm linked.
bool WaitLinked(const std::string& url, const std::string& prefix, double timeout_s,
                std::string* last) {
  core::Bus bus(url, prefix);
  int8_t state = -1;
  bus.Subscribe<sirupp::hardware_status_t>(
      core::Channels{}.hardware_status,
      [&](const sirupp::hardware_status_t& s, const core::ReceiveInfo&) {
        state = s.state;
        *last = s.last_error;
      });
  return HandleUntil(
      bus, [&] { return state == sirupp::hardware_status_t::STATE_LINKED; }, timeout_s);
}

// Sim time the demo lets pass after each set's plan has ended (see the set loop).
constexpr double kAfterSetS = 0.8;

// How long a process of the demo may be silent (wall clock) before the demo's client takes it as
// gone: a PC loaded far beyond its cores stalls a process for seconds (2.4 s measured on the 2-core
// VM at a load average of 14 to 29), and in realtime mode such a stall only costs time (the sim
// waits for every answer). The layout gives the sim's and the controller's watchdogs the same
// room (config/labs/demo.yaml). A process that really stopped is still named: by the watchdogs
// 10 s later, and by the launcher after the set.
constexpr double kStallS = 10.0;

// Waits until `seconds` of sim time have passed on SIM_ARM_STATE (at most 30 s of wall clock).
void WaitSimSeconds(client::Client& rig, double seconds) {
  rig.WatchJoints(true);
  if (rig.Until([&] { return rig.snapshot().sim_arm.has_value(); }, 30.0)) {
    const int64_t until = rig.snapshot().sim_arm->utime + static_cast<int64_t>(seconds * 1e6);
    rig.Until([&] { return rig.snapshot().sim_arm->utime >= until; }, 30.0);
  }
  rig.WatchJoints(false);
}

}  // namespace

namespace {

// --out, or results/demo-TIMESTAMP: created; core::UsageError if it holds anything already.
fs::path NewResultsDir(const runtime::Args& parsed) {
  const fs::path dir =
      parsed.Has("out") ? parsed.String("out") : "results/demo-" + LocalTimestamp();
  if (fs::exists(dir) && !fs::is_empty(dir)) {
    throw core::UsageError("--out " + dir.string() +
                           ": exists and is not empty; choose a new folder");
  }
  fs::create_directories(dir);
  return dir;
}

// Starts the processes (each ready: the bridge once its start guard has passed, docs/launch.md)
// and waits until the bridge has linked the emulated arm; false (with why on `err`) if that does
// not happen.
bool StartRig(launch::Supervisor& supervisor, const launch::Layout& layout, std::ostream& err) {
  if (!supervisor.Start([] { return !runtime::StopRequested(); })) return false;
  std::string last;
  if (!WaitLinked(layout.lcm_url, layout.prefix, 20, &last)) {
    err << "\nsirupp demo: the hardware bridge did not link the emulated arm: " << last;
    return false;
  }
  // The bridge's start guard has passed: the launcher took it as ready only then.
  return true;
}

// Runs each set's plan on the virtual and the emulated real arm, one line per set; returns the
// sets that failed (their plan failed, or the real arm's bridge stopped following during it).
std::vector<std::string> RunSets(const launch::Layout& layout, const core::RobotModel& model,
                                 const std::vector<int>& sets,
                                 const std::vector<std::string>& plans,
                                 launch::Supervisor& supervisor, std::ostream& out) {
  std::vector<std::string> failed_sets;
  // The bridge's state during each set: a fault or an e-stop leaves the real arm behind, and
  // that set's real columns say nothing about the arm.
  core::Bus watch(layout.lcm_url, layout.prefix);
  std::string real_arm_problem;
  watch.Subscribe<sirupp::hardware_status_t>(
      core::Channels{}.hardware_status,
      [&](const sirupp::hardware_status_t& s, const core::ReceiveInfo&) {
        const bool bad = s.state == sirupp::hardware_status_t::STATE_FAULT ||
                         s.state == sirupp::hardware_status_t::STATE_ESTOPPED;
        if (bad && real_arm_problem.empty()) real_arm_problem = s.last_error;
      },
      1000);  // 10 Hz for the length of a set, handled after it
  client::Options rig_options;
  rig_options.lcm_url = layout.lcm_url;
  rig_options.prefix = layout.prefix;
  rig_options.sender = "sirupp demo";
  rig_options.answer_timeout_s = kStallS;
  rig_options.controller_silent_s = kStallS;
  client::Client rig(rig_options);
  for (size_t i = 0; i < sets.size() && !runtime::StopRequested(); ++i) {
    const auto t0 = Clock::now();
    out << "  set " << std::left << std::setw(4) << lab::RomanSet(sets[i]) << std::right << " ("
        << i + 1 << "/" << sets.size() << ") " << PlanTitle(plans[i]) << " ..." << std::flush;
    std::ostringstream plan_out;
    int code = 1;
    try {
      code = RunPlanFile(rig, model, plans[i], /*wait_s=*/3600, plan_out);
      // The report measures each move until 1.25 s of sim time after it is done (the plan
      // ends 0.5 s after): record that much before the next set or the end, whatever the
      // wall clock did, so the set's figures do not depend on the machine's timing.
      if (code == 0) WaitSimSeconds(rig, kAfterSetS);
    } catch (const std::exception& e) {
      plan_out << e.what() << "\n";
    }
    supervisor.Service(0);
    while (watch.HandleAvailable() > 0) {
    }
    if (!real_arm_problem.empty()) {
      // The bridge's fault first, whether it came during a move (the plan ran on) or while a
      // move was being loaded (the plan failed with the bridge's refusal): one fault, one name.
      out << " FAILED: the real arm's bridge stopped following: " << real_arm_problem
          << " (see logs/hardware.log)\n";
      if (code != 0) out << plan_out.str();
      failed_sets.push_back(lab::RomanSet(sets[i]));
    } else if (code == 0) {
      out << " done in " << Rounded(Since(t0), 1) << " s\n";
    } else {
      out << " FAILED\n" << plan_out.str();
      failed_sets.push_back(lab::RomanSet(sets[i]));
    }
  }
  return failed_sets;
}

// The logger's data files of the sets in DIR/data, by name: one per movement set
// (NAME-NN-setK.csv); the file of the start-up, before the first set, holds no move and stays out.
std::vector<std::string> SetDataFiles(const fs::path& dir) {
  std::vector<std::string> data;
  if (fs::exists(dir / "data")) {
    for (const auto& e : fs::directory_iterator(dir / "data")) {
      const std::string name = e.path().filename().string();
      if (e.path().extension() == ".csv" && name.find("-set") != std::string::npos) {
        data.push_back(e.path().string());
      }
    }
  }
  std::sort(data.begin(), data.end());
  return data;
}

// Writes DIR/report from the data files, with the paper's numbers beside ours, and prints its
// Table II; false (and why) if that fails.
bool ReportSets(const std::vector<std::string>& data, const fs::path& dir, std::ostream& out) {
  try {
    logger::ReportOptions report;
    report.out_dir = (dir / "report").string();
    report.analysis.last_move_only = true;  // each set's return to zero is not in Table II
    report.reference = PaperReference();    // the paper's numbers beside ours
    const logger::ReportOutput written =
        logger::WriteReport(logger::ReadInputs(data, report.import), report);
    // The paper's table here; the response table, the plots and the inputs are in report.md.
    const std::string& md = written.markdown;
    const size_t table = md.find("## Table II");
    const size_t next = md.find("\n## ", table == std::string::npos ? 0 : table + 1);
    out << (table == std::string::npos ? md : md.substr(table, next - table)) << "\n"
        << "(response table, plots and inputs: " << (dir / "report" / "report.md").string()
        << ")\n\n";
    return true;
  } catch (const std::exception& e) {
    out << "report failed: " << e.what() << "\n";
    return false;
  }
}

// --model FILE: the virtual arm's model, given to every process of the layout that simulates,
// controls or links the virtual arm or logs the runs (not the emulated real arm, which keeps its
// own). core::UsageError if a process already names a model or none takes it.
void UseVirtualModel(launch::Layout& layout, const std::string& file) {
  const std::string path = fs::absolute(file).string();
  int given = 0;
  for (launch::ProcessSpec& p : layout.processes) {
    if (p.command.empty()) continue;
    const std::string program = fs::path(p.command.front()).filename().string();
    if (program != "sirupp-sim" && program != "sirupp-control" && program != "sirupp-hardware" &&
        program != "sirupp-logger") {
      continue;
    }
    if (std::find(p.command.begin(), p.command.end(), "--model") != p.command.end()) {
      throw core::UsageError("--model: " + layout.file + ":" + std::to_string(p.line) +
                             ": process '" + p.name +
                             "' names its model already; give --model or that, not both");
    }
    p.command.push_back("--model");
    p.command.push_back(path);
    ++given;
  }
  if (given == 0) {
    throw core::UsageError("--model: " + layout.file +
                           " has no sirupp-sim, sirupp-control, sirupp-hardware or sirupp-logger "
                           "process to give it to");
  }
}

// What the demo runs, where, and where its results go.
void PrintDemoHeader(std::ostream& out, const core::RobotModel& model,
                     const std::string& model_file, bool own_model, size_t sets,
                     const launch::Layout& layout, const std::string& layout_file,
                     const fs::path& dir) {
  out << "SIRUPP-LCM demo: the paper's experiment (Table II), headless\n"
      << "  robot: " << core::ModelSummary(model) << "\n"
      << "  virtual arm's model: " << model_file
      << (own_model ? " (the emulated real arm keeps its own)" : "") << "\n"
      << "  sets: " << sets << ", processes: " << layout.processes.size() << " (" << layout_file
      << "), bus " << layout.lcm_url << "\n"
      << "  results: " << dir.string() << "\n\n";
}

}  // namespace

int RunDemo(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  const runtime::Args parsed(
      args, "demo",
      {runtime::Flag("out", "folder for data, report, images and logs").Takes("DIR"),
       runtime::Flag("sets", "movement sets, 1 to 7 or I to VII (default all)").Takes("N", -1),
       runtime::Flag("layout", "lab layout to start (default config/labs/demo.yaml)").Takes("FILE"),
       runtime::Flag("lcm-url", "LCM URL").Takes("URL"),
       runtime::Flag("model",
                     "the virtual arm's model (default config/robots/puma260.yaml); the emulated "
                     "real arm keeps its own")
           .Takes("FILE")},
      kDemoAbout);
  const std::vector<int> sets = MovementSetsArg(parsed);
  const std::string layout_file = runtime::ResolveDataPath(
      parsed.Has("layout") ? parsed.String("layout") : "config/labs/demo.yaml");
  launch::Layout layout = launch::LoadLayout(layout_file);
  layout.lcm_url =
      parsed.Has("lcm-url")
          ? parsed.String("lcm-url")
          : "udpm://239.255.76.67:" + std::to_string(20000 + ::getpid() % 20000) + "?ttl=0";
  // The virtual arm's model, loaded (and so checked) before anything starts.
  const std::string model_file = parsed.Has("model")
                                     ? parsed.String("model")
                                     : runtime::ResolveDataPath(runtime::kDefaultModelFile);
  const core::RobotModel model = core::LoadRobotModel(model_file);
  if (parsed.Has("model")) UseVirtualModel(layout, model_file);
  const fs::path dir = NewResultsDir(parsed);
  std::vector<std::string> plans;
  for (int n : sets) {
    plans.push_back(runtime::ResolveDataPath("config/plans/set" + std::to_string(n) + ".plan"));
  }

  const auto started = Clock::now();
  PrintDemoHeader(out, model, model_file, parsed.Has("model"), sets.size(), layout, layout_file,
                  dir);

  runtime::InstallStopHandlers();
  launch::SupervisorOptions options;
  options.machine = MachineName();
  options.host = launch::ChooseHost(layout, "", options.machine);
  options.bin_dir = ProgramDir();
  options.run_dir = dir.string();
  std::ostringstream events;  // the process log; shown when something goes wrong
  options.events = &events;
  launch::Supervisor supervisor(layout, options);
  out << "[1/4] starting the processes ..." << std::flush;
  const bool ok = StartRig(supervisor, layout, err);
  out << (ok ? " up" : " FAILED") << " after " << Rounded(Since(started), 1) << " s\n";
  std::vector<std::string> failed_sets;
  if (ok) {
    out << "[2/4] running " << sets.size() << " movement sets on the virtual and the emulated real "
        << "arm\n";
    failed_sets = RunSets(layout, model, sets, plans, supervisor, out);
  }
  out << "[3/4] stopping the processes ..." << std::flush;
  supervisor.Stop();
  out << (supervisor.failures().empty() ? " stopped cleanly\n" : " with problems:\n");
  for (const std::string& f : supervisor.failures()) out << "  " << f << "\n";
  if (!ok || !supervisor.failures().empty()) {
    out << "process events:\n" << events.str();
  }
  { std::ofstream(dir / "logs" / "launch.log") << events.str(); }

  const std::vector<std::string> data = SetDataFiles(dir);
  out << "[4/4] Table II report from " << data.size() << " data files\n\n";
  const bool reported = !data.empty() && ReportSets(data, dir, out);
  out << "Results in " << dir.string() << " (" << Rounded(Since(started), 0) << " s in all):\n";
  ListResults(dir, out);
  const bool all = ok && failed_sets.empty() && supervisor.failures().empty() && reported &&
                   !runtime::StopRequested();
  if (!failed_sets.empty()) {
    std::string list;
    for (const std::string& s : failed_sets) list += " " + s;
    out << "sets that failed:" << list << "\n";
  }
  out << (all ? "demo: done\n"
              : "demo: INCOMPLETE (see above and " + (dir / "logs").string() + ")\n");
  return all ? 0 : 1;
}

}  // namespace sirupp::tools
