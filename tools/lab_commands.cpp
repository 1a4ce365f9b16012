#include "tools/lab_commands.hpp"

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <ostream>

#include "core/errors.hpp"
#include "core/model_loader.hpp"
#include "core/yaml_reader.hpp"
#include "hardware/real_arm.hpp"
#include "lab/emulator_fit.hpp"
#include "lab/experiment.hpp"
#include "lab/identify.hpp"
#include "logger/report.hpp"
#include "runtime/args.hpp"
#include "runtime/data_path.hpp"
#include "tools/cli.hpp"

namespace sirupp::tools {

const char* const kFitEmulatorAbout =
    "The SIRUPP paper's experiment in one process: the movement sets (default all seven) on the\n"
    "virtual arm (ODE sim and virtual PIC-SERVOs, lockstep) and on the emulated real arm\n"
    "(emulated PIC-SERVO modules and the arm with its effects, emulated time, no serial line).\n"
    "Prints our Table II (virtual vs real) beside the paper's, row by row, with joint 1's start\n"
    "delay and the multi-joint coupling.\n"
    "docs/emulator-fit.md. Exit 0, 2 for bad arguments or files.\n";

const char* const kIdentifyAbout =
    "Fits the model's joint friction (static, Coulomb per direction, viscous, Stribeck speed) and\n"
    "armature to a real arm's logged data (sirupp-logger data files or LCM logs, e.g. a demo's\n"
    "data/ or `sirupp fit-emulator --data DIR`): a torque regression, then per joint a\n"
    "Nelder-Mead search on a log box from the joint's limits: the virtual arm (sirupp-sim's ODE\n"
    "arm of the model, PIC-SERVO chips giving its efforts as sirupp-control does) follows the\n"
    "logged set-point and the search lowers what Table II measures, per move the mean\n"
    "|virtual - real| over the transient and over the steady state (data without moves: the\n"
    "squared angle error). With movement sets (files a plan ran) only their last moves count by\n"
    "default, the moves Table II measures; --other-moves W weighs the rest. The values can stand\n"
    "in for effects the model lacks (a latency fits as viscous friction and armature).\n"
    "Writes M2 (M with those values; comments kept) and prints the fit per joint (that measure\n"
    "and the RMS, before and after), and how far M's and M2's virtual arms fall behind in the\n"
    "moves any movement set makes, which the data may lack: the fit keeps to values with which\n"
    "the virtual arm makes them within its servos' error limits (--any-moves: not, faster; a\n"
    "warning where M2 would trip a limit). Then\n"
    "`sirupp fit-emulator --evaluate --virtual-model M2`, or `sirupp demo --model M2 --out RUN2`\n"
    "and `sirupp report RUN2/data --compare RUN1/data`, show both runs side by side.\n"
    "docs/emulator-fit.md. Exit 0, 2 for bad arguments or files.\n";

std::vector<int> MovementSetsArg(const runtime::Args& args) {
  if (!args.Has("sets")) return {1, 2, 3, 4, 5, 6, 7};
  std::vector<int> sets;
  for (const std::string& text : args.Values("sets", -1)) {
    const int n = lab::SetFromName(text);  // the paper numbers its sets I to VII; 1 to 7 as well
    if (n == 0) {
      throw core::UsageError("--sets: '" + text +
                             "' is not a movement set; allowed: 1 to 7 or I to VII");
    }
    sets.push_back(n);
  }
  return sets;
}

namespace {

double Since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

// --evaluations: the fit's budget of experiment runs (1..10000 by its declaration).
int EvaluationsArg(const runtime::Args& args, int fallback) {
  return static_cast<int>(args.Integer("evaluations", fallback));
}

// --out: a new file, or --real-arm itself; empty without it.
std::string FitOutFile(const runtime::Args& args) {
  if (!args.Has("out")) return "";
  const std::string out_file = args.String("out");
  if (std::ifstream(out_file).good() && out_file != args.String("real-arm")) {
    throw core::UsageError("fit-emulator: --out " + out_file +
                           ": exists; choose a new file (or give it as --real-arm too)");
  }
  return out_file;
}

// --evaluate: runs the sets once with the effects as they are and prints the table (with
// --data DIR, each set's data file there too).
int Evaluate(const runtime::Args& args, const core::RobotModel& virtual_model,
             const core::RobotModel& model, const hardware::RealArmParams& start,
             const lab::FitOptions& options, std::chrono::steady_clock::time_point started,
             std::ostream& out) {
  std::string data_dir;
  if (args.Has("data")) {
    data_dir = args.String("data");
    std::filesystem::create_directories(data_dir);
  }
  double stray = 0;
  const std::vector<lab::TableRow> table =
      lab::RunExperiment(virtual_model, model, start, options.experiment, data_dir, &stray);
  if (!data_dir.empty()) out << "data files: " << data_dir << "/lab-setN.csv\n";
  out << "\n" << lab::FormatComparison(table, true);
  out << "joints a set does not move stray at most " << std::fixed << std::setprecision(2) << stray
      << " deg from the virtual arm's\n"
      << std::defaultfloat;
  out << "torque at the model's top speed over friction and gravity (the fit keeps >= "
      << core::FormatNumber(lab::kMinSpeedMargin) << "):";
  const std::vector<double> margins = lab::SpeedMargins(start, model);
  for (size_t j = 0; j < margins.size(); ++j) {
    out << " joint " << j + 1 << " " << std::setprecision(3) << margins[j];
  }
  out << "\n" << std::defaultfloat;
  out << "fit cost (table, without " << lab::FormatLeftOutMeans(options.left_out) << ") "
      << core::FormatNumber(lab::FitCost(table, options.coupling_weight, options.left_out)) << "; "
      << std::setprecision(3) << Since(started) << " s\n";
  return 0;
}

// Writes the fitted effects to `out_file`, with where they come from in its head comment.
void WriteFitted(const lab::FitResult& fit, const std::string& out_file) {
  hardware::RealArmParams fitted = fit.params;
  fitted.description = "PUMA 260 real-arm effects fitted to the SIRUPP paper's Table II";
  std::ofstream file(out_file);
  file << hardware::FormatRealArmParams(
      fitted,
      "The emulated real PUMA 260 (sirupp-picservo-emu's default): the physical effects a 1980s\n"
      "geared arm has and the SIRUPP model lacks. Reasoning and sources per value:\n"
      "docs/hardware-emulator.md, \"Real-arm effects\". Written by `sirupp fit-emulator` (fit\n"
      "cost " +
          core::FormatNumber(fit.cost_after) + "): docs/emulator-fit.md.");
  if (!file) throw std::runtime_error("fit-emulator: cannot write " + out_file);
}

}  // namespace

int RunFitEmulator(const std::vector<std::string>& argv, std::ostream& out, std::ostream& err) {
  const runtime::Args args(
      argv, "fit-emulator",
      {runtime::Flag("real-arm",
                     "the effects to start from (default config/hardware/puma260-real.yaml)")
           .Takes("FILE"),
       runtime::Flag("model", "robot model file (default config/robots/puma260.yaml)")
           .Takes("FILE"),
       runtime::Flag("virtual-model",
                     "the virtual arm's model (default: --model), e.g. one sirupp identify wrote")
           .Takes("FILE"),
       runtime::Flag("sets", "movement sets, 1 to 7 or I to VII (default all)").Takes("N", -1),
       runtime::Flag("evaluate", "only run and print the table; no fit").Switch(),
       runtime::Flag("evaluations", "the fit's budget of experiment runs (150)")
           .Takes("N")
           .Integer(1, 10000),
       runtime::Flag("latency-ms",
                     "hold the board's command latency at this value (0..300 ms) instead of "
                     "fitting it")
           .Takes("MS")
           .Range(0, 300),
       runtime::Flag("coupling-weight",
                     "the coupling term's weight in the fit's cost (1; 0 leaves it out)")
           .Takes("W")
           .Range(0, 100),
       runtime::Flag("leave-out",
                     "the paper's means the fit's cost leaves out, still printed and counted: "
                     "rows like V-1 or V-1:steady, comma-separated, or none (default "
                     "V-1:steady,V-3:transient,VI-2:steady,VI-3:transient)")
           .Takes("ROWS"),
       runtime::Flag("out",
                     "write the fitted effects there (refuses to replace a file unless it is "
                     "--real-arm itself)")
           .Takes("FILE"),
       runtime::Flag("data", "with --evaluate: also write each set's data file there")
           .Takes("DIR")},
      kFitEmulatorAbout);
  const std::string model_file = runtime::ModelFileArg(args);
  const core::RobotModel model = core::LoadRobotModel(model_file);
  const core::RobotModel virtual_model =
      args.Has("virtual-model") ? core::LoadRobotModel(args.String("virtual-model")) : model;
  const std::string arm_file = runtime::ResolveDataPath(
      args.Has("real-arm") ? args.String("real-arm") : "config/hardware/puma260-real.yaml");
  const hardware::RealArmParams start = hardware::LoadRealArmParams(arm_file, model);
  lab::FitOptions options;
  options.experiment.sets = MovementSetsArg(args);
  options.max_evaluations = EvaluationsArg(args, options.max_evaluations);
  if (args.Has("latency-ms")) options.latency_s = args.Numbers("latency-ms", 1)[0] / 1e3;
  if (args.Has("coupling-weight")) options.coupling_weight = args.Numbers("coupling-weight", 1)[0];
  if (args.Has("leave-out")) {
    try {
      options.left_out = lab::ParseLeftOutMeans(args.String("leave-out"));
    } catch (const std::invalid_argument& e) {
      throw core::UsageError(std::string("--leave-out: ") + e.what());
    }
  }
  const std::string out_file = FitOutFile(args);
  const auto started = std::chrono::steady_clock::now();
  out << "virtual arm: " << virtual_model.name
      << (args.Has("virtual-model") ? " (" + args.String("virtual-model") + ")" : "")
      << "; emulated real arm: " << arm_file << "\n";
  if (args.Switch("evaluate")) {
    return Evaluate(args, virtual_model, model, start, options, started, out);
  }
  options.progress = [&](int evaluation, double cost, const std::string& what) {
    err << "  [" << evaluation << "] cost " << core::FormatNumber(std::round(cost * 1000) / 1000)
        << ": " << what << "\n";
  };
  const lab::FitResult fit = lab::FitEmulator(virtual_model, model, start, options);
  out << "fit: cost " << core::FormatNumber(fit.cost_before) << " -> "
      << core::FormatNumber(fit.cost_after) << " in " << fit.evaluations << " runs of the "
      << options.experiment.sets.size() << " sets, " << std::setprecision(3) << Since(started)
      << " s; the cost leaves out " << lab::FormatLeftOutMeans(options.left_out) << "\n";
  for (const std::string& line : fit.fitted) out << "  " << line << "\n";
  out << "\n" << lab::FormatComparison(fit.table, true);
  out << "joints a set does not move stray at most " << std::fixed << std::setprecision(2)
      << fit.hold_stray_deg << " deg from the virtual arm's\n"
      << std::defaultfloat;
  if (!out_file.empty()) {
    WriteFitted(fit, out_file);
    out << "wrote " << out_file << "\n";
  }
  return 0;
}

namespace {

// identify's table: per fitted joint, the RMS and each value before -> after.
void PrintIdentification(std::ostream& out, const lab::IdentifyResult& result, size_t tables,
                         double seconds) {
  out << "identified from " << tables << " data tables in " << result.evaluations
      << " simulations (" << std::setprecision(3) << seconds << " s)\n\n"
      << "| joint | samples | moves' means before (deg) | after (deg) | rms before (deg) | "
         "rms after (deg) | static | Coulomb +/- | viscous | Stribeck (deg/s) | armature |\n"
      << "|---|---:|---:|---:|---:|---:|---|---|---|---|---|\n";
  auto f = [](double v) { return core::FormatNumber(std::round(v * 1e4) / 1e4); };
  for (const lab::JointIdentification& id : result.joints) {
    const core::Friction& a = id.friction_before;
    const core::Friction& b = id.friction_after;
    const double deg = 3.14159265358979323846 / 180;
    auto mean = [&](double v) { return std::isnan(v) ? std::string("-") : f(v); };
    out << "| " << id.joint << " | " << id.samples << " | " << mean(id.table_before) << " | "
        << mean(id.table_after) << " | " << f(id.rms_before_deg) << " | " << f(id.rms_after_deg)
        << " | " << f(a.static_effort) << " -> " << f(b.static_effort) << " | "
        << f(a.coulomb_positive) << "/" << f(a.coulomb_negative) << " -> " << f(b.coulomb_positive)
        << "/" << f(b.coulomb_negative) << " | " << f(a.viscous) << " -> " << f(b.viscous) << " | "
        << f(a.stribeck_velocity / deg) << " -> " << f(b.stribeck_velocity / deg) << " | "
        << f(id.armature_before) << " -> " << f(id.armature_after) << " |\n";
  }
}

// Whether M and M2's virtual arms make the moves every movement set makes (lab::CheckMoves), which
// the data may lack: a table, and a warning for each joint of M2 over its error limit.
void PrintMovesCheck(std::ostream& out, std::ostream& err, const core::RobotModel& model,
                     const lab::IdentifyResult& result) {
  std::vector<int> joints;
  for (const lab::JointIdentification& id : result.joints) joints.push_back(id.joint);
  if (joints.empty()) return;
  std::vector<lab::LagCheck> before, after;
  try {
    before = lab::CheckMoves(model, joints);
    after = lab::CheckMoves(result.model, joints);
  } catch (const std::runtime_error& e) {  // the simulation blew up in ODE
    err << "sirupp identify: warning: the moves check could not be simulated: " << e.what() << "\n";
    return;
  }
  out << "\nthe virtual arm on the moves every movement set makes (ready -> zero; each joint "
         "0 -> 90 deg and back, alone and together; default speeds): the largest lag behind "
         "the set-point\n\n"
      << "| joint | M (counts) | M2 (counts) | error limit (counts) | M2's worst move |\n"
      << "|---|---:|---:|---:|---|\n";
  for (size_t k = 0; k < after.size(); ++k) {
    const lab::LagCheck& a = after[k];
    out << "| " << a.joint << " | " << before[k].worst_counts << " | " << a.worst_counts << " | "
        << a.limit_counts << " | " << a.move << " |\n";
    if (a.over()) {
      err << "sirupp identify: warning: with the identified model, joint " << a.joint << " ("
          << result.model.joints[static_cast<size_t>(a.joint - 1)].name << ") falls "
          << a.worst_counts << " counts behind in the move '" << a.move
          << "', over its error limit of " << a.limit_counts
          << ": the virtual arm would stop with POS_ERR there. The data lack such a move: fit "
             "without --any-moves, or with data that has it\n";
    }
  }
}

}  // namespace

int RunIdentify(const std::vector<std::string>& argv, std::ostream& out, std::ostream& err) {
  std::vector<std::string> files;
  size_t i = 0;
  for (; i < argv.size() && argv[i].rfind("--", 0) != 0; ++i) files.push_back(argv[i]);
  const runtime::Args args(
      std::vector<std::string>(argv.begin() + static_cast<std::ptrdiff_t>(i), argv.end()),
      "identify",
      {runtime::Flag("model", "the model M whose friction and armature are fitted (required)")
           .Takes("FILE"),
       runtime::Flag("out", "the identified model file M2, new (required)").Takes("FILE"),
       runtime::Flag("joints", "the joints to fit (default: every joint the set-point moves)")
           .Takes("N", -1)
           .Integer(1, runtime::Flag::kMany),
       runtime::Flag("evaluations", "simulations of the data the fit may run (150)")
           .Takes("N")
           .Integer(5, 100000),
       runtime::Flag("last-move",
                     "simulate and fit only each file's last move, from where the real arm "
                     "starts it (a movement set first returns the arm to zero)")
           .Switch(),
       runtime::Flag("other-moves",
                     "the weight of the moves other than the movement sets' last ones (a "
                     "return to zero, a manual part) in the fit (default 0 with movement sets, "
                     "else 1)")
           .Takes("W")
           .Range(0, 1),
       runtime::Flag("any-moves",
                     "do not require values with which the virtual arm makes the moves any "
                     "movement set makes (ready to zero, each joint 0 to 90 deg and back, alone "
                     "and together) within its servos' error limits; faster, but M2 may trip "
                     "them on moves the data lack")
           .Switch()},
      kIdentifyAbout);
  if (files.empty())
    throw core::UsageError("identify: give at least one DATA file (before the options)");
  if (!args.Has("model")) throw core::UsageError("identify: --model M is required");
  if (!args.Has("out")) throw core::UsageError("identify: --out M2 is required");
  const std::string model_file = args.String("model");
  const std::string out_file = args.String("out");
  if (std::ifstream(out_file).good()) {
    throw core::UsageError("identify: --out " + out_file + ": exists; choose a new file");
  }
  const core::RobotModel model = core::LoadRobotModel(model_file);
  lab::IdentifyOptions options;
  if (args.Has("joints")) {
    for (double j : args.Numbers("joints", -1)) {  // whole and >= 1 by its declaration
      if (j > model.num_joints()) {
        throw core::UsageError("identify: --joints: '" + core::FormatNumber(j) +
                               "' is not allowed; allowed: a whole number from 1 to " +
                               std::to_string(model.num_joints()));
      }
      options.joints.push_back(static_cast<int>(j));
    }
  }
  options.max_evaluations =
      static_cast<int>(args.Integer("evaluations", options.max_evaluations));  // 5..100000
  options.last_move_only = args.Has("last-move");
  if (args.Has("other-moves")) options.other_moves_weight = args.Number("other-moves", 0);
  options.require_moves = !args.Has("any-moves");
  {
    // Before any fitting: every joint that may be fitted can be written back into M2.
    std::vector<int> joints = options.joints;
    if (joints.empty()) {
      for (int j = 1; j <= model.num_joints(); ++j) joints.push_back(j);
    }
    lab::CheckModelRewritable(core::ReadTextFile(model_file), model_file, model, joints);
  }
  logger::ImportOptions import;
  const std::vector<logger::RunTable> tables = logger::ReadInputs(files, import);
  const auto started = std::chrono::steady_clock::now();
  const lab::IdentifyResult result = lab::Identify(model, tables, options);
  const std::string text =
      lab::RewriteModelText(core::ReadTextFile(model_file), model_file, model, result);
  {
    std::ofstream file(out_file);
    file << text;
    if (!file) throw std::runtime_error("identify: cannot write " + out_file);
  }
  core::LoadRobotModel(out_file);  // what was written loads
  PrintIdentification(out, result, tables.size(), Since(started));
  PrintMovesCheck(out, err, model, result);
  out << "\nwrote " << out_file << "\n";
  err << "sirupp identify: next: sirupp fit-emulator --evaluate --virtual-model " << out_file
      << "\n";
  return 0;
}

}  // namespace sirupp::tools
