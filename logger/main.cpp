// sirupp-logger: the paper's data files from a running rig. Thin main over logger/logger_node.hpp.

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <optional>
#include <string>

#include "core/bus.hpp"
#include "core/errors.hpp"
#include "core/model_loader.hpp"
#include "logger/raw_settings.hpp"
#include "logger/recorder.hpp"
#include "runtime/args.hpp"
#include "runtime/data_path.hpp"
#include "runtime/process_main.hpp"

namespace {

using sirupp::runtime::Flag;

constexpr const char* kAbout =
    "Writes the paper's data files: per sample time the set-point (ARM_SETPOINT), the virtual\n"
    "arm (SIM_ARM_STATE) and the real arm (REAL_ARM_STATE) joint positions, as CSV with a\n"
    "commented header, one file per movement set (CONTROLLER_STATUS plan runs):\n"
    "DIR/NAME-NN-SET.csv (--split none: DIR/NAME.csv). DIR default logs, NAME default\n"
    "sirupp-YYYYmmdd-HHMMSS. Rows every servo tick of the model (--rate HZ for another clock);\n"
    "a stream older than --max-age (0.025 s) leaves its cell empty. Rows reach the file within\n"
    "0.1 s; stop with Ctrl-C (the files get their '# end' line). On udpm the socket asks for a\n"
    "--recv-buf of 2097152 bytes (0: LCM's default), so a busy machine does not drop datagrams\n"
    "(the kernel caps it at net.core.rmem_max). Started again with data files of NAME in DIR\n"
    "(a restart), it continues the run in new files: NAME-03-set2.csv goes on in\n"
    "NAME-03-set2.1.csv; no file is ever replaced. LOGGER_COMMAND stops the run and starts\n"
    "new named ones (answered on LOGGER_REPLY; the lab panel's Record view). Report: sirupp\n"
    "report DIR. Raw logs: docs/logging.md (\"Raw logs\").\n";

double PositiveSeconds(const sirupp::runtime::Args& args, const std::string& flag,
                       double fallback) {
  if (!args.Has(flag)) return fallback;
  const double value = args.Numbers(flag, 1)[0];
  if (!(value > 0)) {
    throw sirupp::core::UsageError("sirupp-logger: --" + flag + " " +
                                   sirupp::core::FormatNumber(value) + ": must be > 0 s");
  }
  return value;
}

// A udpm URL (given, else LCM_DEFAULT_URL, else LCM's default) with recv_buf_size=BYTES added
// unless it names one; other providers (memq, file, tcpq) unchanged.
std::string WithReceiveBuffer(std::string url, int64_t bytes) {
  if (bytes <= 0) return url;
  if (url.empty()) {
    const char* from_env = std::getenv("LCM_DEFAULT_URL");
    url = from_env != nullptr && *from_env != '\0' ? from_env : "udpm://239.255.76.67:7667?ttl=0";
  }
  if (url.rfind("udpm://", 0) != 0 || url.find("recv_buf_size=") != std::string::npos) return url;
  return url + (url.find('?') == std::string::npos ? "?" : "&") +
         "recv_buf_size=" + std::to_string(bytes);
}

// The data files' options: --out, --name, --split, --rate, --max-age, --idle, --velocities,
// --efforts, --note.
sirupp::logger::LoggerOptions LoggerOptionsFromArgs(const sirupp::runtime::Args& args,
                                                    const sirupp::core::RobotModel& model) {
  sirupp::logger::LoggerOptions options;
  if (args.Has("out")) options.out_dir = args.String("out");
  if (args.Has("name")) {
    options.name = args.String("name");
    if (options.name.empty() || options.name.find('/') != std::string::npos) {
      throw sirupp::core::UsageError("sirupp-logger: --name '" + options.name +
                                     "': a file name stem without '/' is needed");
    }
  }
  if (args.Has("split")) {
    const std::string split = args.String("split");
    if (split != "plan" && split != "none") {
      throw sirupp::core::UsageError("sirupp-logger: --split '" + split +
                                     "' is not allowed; allowed: plan, none");
    }
    options.split_per_plan = split == "plan";
  }
  const double period_s = 1.0 / PositiveSeconds(args, "rate", 1.0 / model.servo_tick_s);
  options.aligner.period_us = std::max<int64_t>(1, std::llround(period_s * 1e6));
  options.aligner.max_age_us = std::llround(
      PositiveSeconds(args, "max-age", static_cast<double>(options.aligner.max_age_us) * 1e-6) *
      1e6);
  options.aligner.idle_us = std::llround(PositiveSeconds(args, "idle", 0.05) * 1e6);
  options.velocities = args.Switch("velocities");
  options.efforts = args.Switch("efforts");
  if (args.Has("note")) {
    for (const std::string& word : args.Values("note", -1)) {
      options.note += (options.note.empty() ? "" : " ") + word;
    }
  }
  return options;
}

// --recv-buf in bytes (default 2 MiB; 0: LCM's default).
int64_t ReceiveBufferArg(const sirupp::runtime::Args& args) {
  double recv_buf = 2097152;
  if (args.Has("recv-buf")) {
    recv_buf = args.Numbers("recv-buf", 1)[0];
    if (recv_buf < 0 || recv_buf != std::floor(recv_buf) || recv_buf > 1 << 30) {
      throw sirupp::core::UsageError("sirupp-logger: --recv-buf " +
                                     sirupp::core::FormatNumber(recv_buf) +
                                     ": allowed whole bytes from 0 to 1073741824");
    }
  }
  return static_cast<int64_t>(recv_buf);
}

// The files written, then the error that ended the logging if there was one: exit 1 then.
int ListFiles(const sirupp::logger::LoggerStats& stats) {
  for (const std::string& file : stats.files) std::cerr << "  " << file << "\n";
  if (!stats.error.empty()) {
    std::cerr << "sirupp-logger: " << stats.error << "\n";
    return 1;
  }
  return 0;
}

// --from-log LOG: the data files written again from a raw log, without a bus. The live logger's
// settings come from the log (its LOGGER_PASS), except those given here.
int ReplayFromLog(const sirupp::runtime::Args& args) {
  const std::string log = args.String("from-log");
  if (args.Has("raw") || args.Has("lcm-url") || args.Has("duration")) {
    throw sirupp::core::UsageError(
        "sirupp-logger: --from-log reads a recorded log: --raw, --lcm-url and --duration do not "
        "apply");
  }
  const std::optional<sirupp::core::LoggerPass> recorded = sirupp::logger::RecordedSettings(
      log, args.Has("prefix") ? std::optional<std::string>(args.String("prefix")) : std::nullopt);
  const bool recorded_model = recorded && !recorded->model_file.empty() && !args.Has("model");
  const sirupp::core::RobotModel model = sirupp::core::LoadRobotModel(
      recorded_model ? sirupp::runtime::ResolveDataPath(recorded->model_file)
                     : sirupp::runtime::ModelFileArg(args));
  sirupp::logger::LoggerOptions options = LoggerOptionsFromArgs(args, model);
  std::string prefix = args.Has("prefix") ? args.String("prefix") : "";
  if (recorded) {
    sirupp::logger::TakeRecordedSettings(
        *recorded, [&args](const std::string& flag) { return args.Has(flag); }, options);
    if (!args.Has("prefix")) prefix = recorded->prefix;
  }
  const sirupp::logger::LoggerStats stats =
      sirupp::logger::ReplayRawLog(log, model, options, prefix);
  std::cerr << "sirupp-logger: from " << log << ": " << stats.rows << " rows in "
            << stats.files.size() << " file(s)\n";
  return ListFiles(stats);
}

int Run(const std::vector<std::string>& argv) {
  const sirupp::runtime::Args args(
      argv, "sirupp-logger",
      {Flag("out", "folder of the data files (default logs)").Takes("DIR"),
       Flag("name", "file name stem (default sirupp-YYYYmmdd-HHMMSS)").Takes("NAME"),
       Flag("split", "one file per movement set (plan) or one for the run (none)")
           .Takes("MODE")
           .OneOf({"plan", "none"}),
       Flag("rate", "row clock in Hz (default: the model's servo tick)").Takes("HZ"),
       Flag("max-age", "a stream older than this leaves its cell empty (default 0.025)").Takes("S"),
       Flag("idle", "rows stop after the bus is quiet this long (default 0.05)").Takes("S"),
       Flag("velocities", "also the joint velocities").Switch(),
       Flag("efforts", "also the joint efforts").Switch(),
       Flag("note", "a line for the files' header").Takes("TEXT", -1),
       Flag("duration", "stop after this many seconds").Takes("S"),
       Flag("recv-buf", "udpm receive buffer (default 2097152; 0: LCM's default)").Takes("BYTES"),
       sirupp::runtime::ModelFlag(), Flag("lcm-url", "LCM URL").Takes("URL"),
       Flag("prefix", "channel prefix of the rig").Takes("PREFIX"),
       Flag("raw",
            "also record every message on the bus in lcm-logger's format, stamped with the "
            "receive times the rows were aligned with (each recorded run: a new file)")
           .Takes("FILE"),
       Flag("from-log",
            "no bus: write the data files again from such a raw log, with the live logger's "
            "settings as recorded in it (options given here win)")
           .Takes("LOG")},
      kAbout);
  if (args.Has("from-log")) return ReplayFromLog(args);
  const sirupp::core::RobotModel model =
      sirupp::core::LoadRobotModel(sirupp::runtime::ModelFileArg(args));
  sirupp::logger::LoggerOptions options = LoggerOptionsFromArgs(args, model);
  const double duration_s = PositiveSeconds(args, "duration", 0);
  const int64_t recv_buf = ReceiveBufferArg(args);
  const std::string prefix = args.Has("prefix") ? args.String("prefix") : "";
  if (args.Has("raw")) options.raw_log = args.String("raw");
  sirupp::core::Bus bus(
      WithReceiveBuffer(args.Has("lcm-url") ? args.String("lcm-url") : "", recv_buf), prefix);
  sirupp::logger::Recorder node(bus, model, options);
  std::cerr << "sirupp-logger: " << model.name << ", files " << options.out_dir << "/"
            << node.name() << (options.split_per_plan ? "-NN-SET.csv" : ".csv") << ", a row every "
            << options.aligner.period_us << " us, on " << bus.url()
            << (node.raw_log().empty() ? "" : "; raw log " + node.raw_log()) << std::endl;
  if (!node.continues().empty()) {
    std::cerr << "sirupp-logger: " << node.continues()
              << " exists: continuing that run in new files (a restart; no file is replaced)"
              << std::endl;
  }
  const auto start = std::chrono::steady_clock::now();
  sirupp::runtime::ServiceUntilSignal([&] {
    node.Service(20);
    if (node.failed()) return false;
    return duration_s <= 0 ||
           std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() <
               duration_s;
  });
  node.Close();
  const sirupp::logger::LoggerStats stats = node.stats();
  std::cerr << "sirupp-logger: " << stats.rows << " rows in " << stats.files.size() << " file(s);"
            << " messages set " << stats.samples[0] << ", virt " << stats.samples[1] << ", real "
            << stats.samples[2] << "; lost set " << stats.lost[0] << ", virt " << stats.lost[1]
            << ", real " << stats.lost[2];
  if (stats.kernel_dropped > 0) {
    std::cerr << " (" << stats.kernel_dropped
              << " per-tick datagrams dropped by the kernel: its buffer was full)";
  }
  std::cerr << "\n";
  return ListFiles(stats);
}

}  // namespace

int main(int argc, char** argv) {
  return sirupp::runtime::ProcessMain(argc, argv, "sirupp-logger", Run);
}
