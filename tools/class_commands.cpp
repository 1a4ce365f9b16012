#include "tools/class_commands.hpp"

#include <chrono>
#include <stdexcept>
#include <ostream>
#include <thread>

#include "class/class_config.hpp"
#include "class/class_server.hpp"
#include "core/errors.hpp"
#include "grade/notebook_assignment.hpp"
#include "runtime/args.hpp"
#include "runtime/data_path.hpp"
#include "runtime/process_main.hpp"
#include "tools/launch_commands.hpp"

namespace sirupp::tools {
namespace {

const char* const kServeAbout =
    "Serves a class on this computer: a private rig per student (sim, control, logger and the\n"
    "panel's page), started on the student's first visit, stopped after the class file's idle\n"
    "timeout; the teacher's page at /teacher/. Issues missing tokens first and appends their\n"
    "addresses to DATA/tokens.csv. Ctrl-C stops every rig. See docs/class.md.\n";

runtime::Flag ClassFileFlag() {
  return runtime::Flag("class-file", "the class file (docs/class.md)").Positional("CLASS.yaml");
}

}  // namespace

int RunClassCheck(const std::vector<std::string>& args, std::ostream& out) {
  const runtime::Args parsed(args, "class check", {ClassFileFlag()},
                             "Checks a class file; prints what it sets up.\n");
  const classroom::ClassConfig config = classroom::LoadClassConfig(parsed.String("class-file"));
  // Notebook assignments: each one's hidden tests read as the server will (names, points).
  std::string notebook_lines;
  if (config.notebooks) {
    for (const classroom::NotebookAssignment& assignment : config.notebooks->assignments) {
      std::vector<grade::NotebookTest> tests;
      try {
        tests = grade::ReadNotebookTests(assignment.tests);
      } catch (const std::runtime_error& error) {
        throw core::UsageError(config.file + ": notebooks: assignments: " + assignment.name +
                               ": " + error.what());
      }
      const std::string exposed = grade::HiddenTestsExposed(assignment.tests, ProgramDir());
      if (!exposed.empty()) {
        throw core::UsageError(config.file + ": notebooks: assignments: " + assignment.name +
                               ": tests: " + exposed);
      }
      double points = 0;
      for (const grade::NotebookTest& test : tests) points += test.points;
      notebook_lines += "  notebook assignment " + assignment.name + ": " + assignment.notebook +
                        ", " + std::to_string(tests.size()) + " hidden tests, " +
                        core::FormatApprox(points) + " points\n";
    }
  }
  out << config.file << ": ok: class " << config.name << ", " << config.students.size()
      << " students, robot " << config.robot << ", at most " << config.max_rigs << " rigs ("
      << (config.pin_rigs ? "each on one CPU, " : "") << "sims pacing " << config.pace_ticks
      << " ticks per sleep), idle timeout " << config.idle_timeout_s << " s, data "
      << config.data_dir << ", listens on " << config.listen << ":" << config.port
      << (config.tls_cert.empty() ? "" : " (HTTPS)") << "\n";
  if (config.real_arm) {
    out << "  real arm: the bridge on " << config.real_arm->lcm_url << ", turns of "
        << core::FormatApprox(config.real_arm->turn_s) << " s\n";
  }
  if (!config.grading_suite.empty()) {
    out << "  grading: " << config.grading_suite << "\n";
  }
  out << notebook_lines;
  return 0;
}

int RunClassTokens(const std::vector<std::string>& args, std::ostream& out) {
  const runtime::Args parsed(
      args, "class tokens",
      {ClassFileFlag(),
       runtime::Flag("reissue",
                     "a new token for NAME (a student, or teacher); the old one stops "
                     "working")
           .Takes("NAME")},
      "Issues the missing tokens (or, with --reissue, a new one), appends each address to\n"
      "DATA/tokens.csv and prints it. Tokens are stored hashed: an address cannot be shown again,\n"
      "only reissued. Takes effect in a running server at once.\n");
  const classroom::ClassConfig config = classroom::LoadClassConfig(parsed.String("class-file"));
  std::vector<std::pair<std::string, std::string>> rows;
  if (parsed.Has("reissue")) {
    rows.push_back(classroom::ReissueToken(config, config.port, parsed.String("reissue")));
  } else {
    rows = classroom::IssueMissingTokens(config, config.port);
  }
  for (const auto& [name, address] : rows) out << name << "," << address << "\n";
  out << rows.size() << " token(s) issued; every address so far: " << classroom::HandoutFile(config)
      << "\n";
  return 0;
}

int RunClassServe(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  const runtime::Args parsed(args, "class serve",
                             {ClassFileFlag(),
                              runtime::Flag("port", "override the class file's port (0: any free)")
                                  .Takes("N")
                                  .Integer(0, 65535),
                              runtime::Flag("duration", "stop after S seconds (tests)").Takes("S")},
                             kServeAbout);
  classroom::ClassConfig config = classroom::LoadClassConfig(parsed.String("class-file"));
  if (parsed.Has("port")) config.port = static_cast<int>(parsed.Integer("port", config.port));
  const double duration = parsed.Number("duration", 0);
  if (parsed.Has("duration") && !(duration > 0)) {
    throw core::UsageError("--duration " + parsed.String("duration") + ": expected seconds > 0");
  }
  classroom::ServeOptions options;
  options.bin_dir = ProgramDir();
  options.panel_web_dir = runtime::ResolveDataPath("panel/web");
  options.class_web_dir = runtime::ResolveDataPath("class/web");
  options.config_dir = runtime::ResolveDataPath("config");
  options.log = &err;
  runtime::InstallStopHandlers();
  classroom::ClassServer server(config, options);
  const int port = server.Bind();
  for (const auto& [name, address] : classroom::IssueMissingTokens(config, port)) {
    out << "new token: " << name << "," << address << "\n";
  }
  out << "sirupp class: " << config.name << " at " << classroom::BaseUrl(config, port)
      << "/ (teacher: " << classroom::BaseUrl(config, port)
      << "/teacher/?token=...; every address: " << classroom::HandoutFile(config) << ")"
      << std::endl;
  std::thread serving([&] { server.Serve(); });
  const auto start = std::chrono::steady_clock::now();
  while (!runtime::StopRequested() &&
         (duration <= 0 ||
          std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() <
              duration)) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  err << "sirupp class: stopping every rig\n";
  server.Stop();
  serving.join();
  return 0;
}

}  // namespace sirupp::tools
