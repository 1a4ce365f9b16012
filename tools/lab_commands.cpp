#include "tools/lab_commands.hpp"

#include <chrono>
#include <fstream>
#include <iomanip>
#include <ostream>
#include <strings.h>

#include "core/errors.hpp"
#include "core/model_loader.hpp"
#include "hardware/real_arm.hpp"
#include "lab/emulator_fit.hpp"
#include "lab/experiment.hpp"
#include "tools/args.hpp"
#include "tools/cli.hpp"

namespace sirupp::tools {

const char* const kFitEmulatorUsage =
    "usage: sirupp fit-emulator [--real-arm FILE] [--model FILE] [--virtual-model FILE]\n"
    "                           [--sets N...] [--evaluate] [--evaluations N] [--out FILE]\n"
    "The SIRUPP paper's experiment in one process: the movement sets (default all seven) on the\n"
    "virtual arm (ODE sim and virtual PIC-SERVOs, lockstep) and on the emulated real arm\n"
    "(emulated PIC-SERVO modules and the arm with its effects, emulated time, no serial line).\n"
    "Prints our Table II (virtual vs real) beside the paper's, row by row, with joint 1's start\n"
    "delay and the multi-joint coupling.\n"
    "  --real-arm FILE       the effects to start from (default config/hardware/puma260-real.yaml)\n"
    "  --model FILE          the robot model of the real arm (default config/robots/puma260.yaml)\n"
    "  --virtual-model FILE  the virtual arm's model (default: --model); e.g. one `sirupp\n"
    "                        identify` wrote, to see how much closer it comes\n"
    "  --evaluate            only run and print the table; no fit\n"
    "  --evaluations N       the fit's budget of experiment runs (default 150)\n"
    "  --out FILE            write the fitted effects there (refuses to replace a file unless it\n"
    "                        is --real-arm itself)\n"
    "docs/emulator-fit.md. Exit 0, 2 for bad arguments or files.\n";

const char* const kIdentifyUsage = "usage: sirupp identify DATA... --model M --out M2\n";

namespace {

std::vector<int> ParseSets(const Args& args) {
  std::vector<int> sets;
  if (!args.Has("sets")) return {1, 2, 3, 4, 5, 6, 7};
  for (const std::string& text : args.Values("sets", -1)) {
    int n = 0;
    for (int k = 1; k <= 7; ++k) {
      if (strcasecmp(text.c_str(), lab::RomanSet(k)) == 0 || text == std::to_string(k)) n = k;
    }
    if (n == 0) {
      throw core::UsageError("--sets: '" + text +
                             "' is not a movement set; allowed: 1 to 7 or I to VII");
    }
    sets.push_back(n);
  }
  return sets;
}

double Since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

}  // namespace

int RunFitEmulator(const std::vector<std::string>& argv, std::ostream& out, std::ostream& err) {
  const Args args(argv, "fit-emulator",
                  {{"real-arm", "FILE"},
                   {"model", "FILE"},
                   {"virtual-model", "FILE"},
                   {"sets", "N..."},
                   {"evaluate", "(switch)"},
                   {"evaluations", "N"},
                   {"out", "FILE"}});
  const std::string model_file =
      ResolveDataPath(args.Has("model") ? args.String("model") : "config/robots/puma260.yaml");
  const core::RobotModel model = core::LoadRobotModel(model_file);
  const core::RobotModel virtual_model =
      args.Has("virtual-model") ? core::LoadRobotModel(args.String("virtual-model")) : model;
  const std::string arm_file = ResolveDataPath(
      args.Has("real-arm") ? args.String("real-arm") : "config/hardware/puma260-real.yaml");
  const hardware::RealArmParams start = hardware::LoadRealArmParams(arm_file, model);
  lab::FitOptions options;
  options.experiment.sets = ParseSets(args);
  if (args.Has("evaluations")) {
    const double n = args.Numbers("evaluations", 1)[0];
    if (!(n >= 1 && n <= 10000) || n != std::floor(n)) {
      throw core::UsageError("fit-emulator: --evaluations " + core::FormatNumber(n) +
                             ": allowed a whole number 1..10000");
    }
    options.max_evaluations = static_cast<int>(n);
  }
  std::string out_file;
  if (args.Has("out")) {
    out_file = args.String("out");
    if (std::ifstream(out_file).good() && out_file != args.String("real-arm")) {
      throw core::UsageError("fit-emulator: --out " + out_file +
                             ": exists; choose a new file (or give it as --real-arm too)");
    }
  }
  const auto started = std::chrono::steady_clock::now();
  out << "virtual arm: " << virtual_model.name
      << (args.Has("virtual-model") ? " (" + args.String("virtual-model") + ")" : "")
      << "; emulated real arm: " << arm_file << "\n";
  if (args.Switch("evaluate")) {
    const std::vector<lab::TableRow> table =
        lab::RunExperiment(virtual_model, model, start, options.experiment);
    out << "\n" << lab::FormatComparison(table, true);
    out << "fit cost " << core::FormatNumber(lab::FitCost(table)) << "; "
        << std::setprecision(3) << Since(started) << " s\n";
    return 0;
  }
  options.progress = [&](int evaluation, double cost, const std::string& what) {
    err << "  [" << evaluation << "] cost " << core::FormatNumber(std::round(cost * 1000) / 1000)
        << ": " << what << "\n";
  };
  const lab::FitResult fit = lab::FitEmulator(virtual_model, model, start, options);
  out << "fit: cost " << core::FormatNumber(fit.cost_before) << " -> "
      << core::FormatNumber(fit.cost_after) << " in " << fit.evaluations << " runs of the "
      << options.experiment.sets.size() << " sets, " << std::setprecision(3) << Since(started)
      << " s\n";
  for (const std::string& line : fit.fitted) out << "  " << line << "\n";
  out << "\n" << lab::FormatComparison(fit.table, true);
  if (!out_file.empty()) {
    hardware::RealArmParams fitted = fit.params;
    fitted.description = "PUMA 260 real-arm effects fitted to the SIRUPP paper's Table II";
    std::ofstream file(out_file);
    file << hardware::FormatRealArmParams(
        fitted,
        "The emulated real PUMA 260 (sirupp-picservo-emu's default): the physical effects a 1980s\n"
        "geared arm has and the SIRUPP model lacks. Reasoning and sources per value:\n"
        "docs/hardware-emulator.md, \"Real-arm effects\". Written by `sirupp fit-emulator` (fit\n"
        "cost " + core::FormatNumber(fit.cost_after) + "): docs/emulator-fit.md.");
    if (!file) throw std::runtime_error("fit-emulator: cannot write " + out_file);
    out << "wrote " << out_file << "\n";
  }
  return 0;
}

int RunIdentify(const std::vector<std::string>&, std::ostream&, std::ostream&) {
  throw core::UsageError("identify: not built yet");
}

}  // namespace sirupp::tools
