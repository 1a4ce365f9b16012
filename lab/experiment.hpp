#pragma once
// The SIRUPP paper's experiment without processes or a serial line: each movement set (joints 1, 2
// and 3 from 0 to 90 degrees, alone, in pairs and all three) run on the virtual arm (sirupp-sim's
// ODE arm under sirupp-control's virtual PIC-SERVOs, in lockstep) and on the emulated real arm
// (the emulator's PIC-SERVO modules, fed the NMC packets the bridge sends, and its EmulatedArm,
// in emulated time), tick for tick; then the Table II analysis of the logger (logger/analysis.hpp)
// on the result. Reads the models and the real-arm effects; writes nothing. docs/emulator-fit.md.

#include <optional>
#include <string>
#include <vector>

#include "core/robot_model.hpp"
#include "hardware/real_arm.hpp"
#include "logger/data_file.hpp"

namespace sirupp::lab {

// The joints (1-based) movement set `set` (1..7) moves. Throws std::invalid_argument otherwise.
std::vector<int> SetJoints(int set);
const char* RomanSet(int set);  // "I" .. "VII"
// The set named "I" .. "VII" (any case) or "1" .. "7"; 0 for anything else.
int SetFromName(const std::string& name);

// One row of the paper's Table II, in our numbering: the paper lists each set's joints as 1, 2
// (and 3) in the order they appear; sets V and VI move joints 1 + 3 and 2 + 3 (config/plans), so
// their rows "1" and "2" are those joints (docs/emulator-fit.md says why).
struct PaperRow {
  int set = 0;
  int joint = 0;             // ours, 1-based
  double transient_deg = 0;  // mean |virtual - real| in the transient
  double steady_deg = 0;     // ... in the steady state
};
const std::vector<PaperRow>& PaperTable();  // the 12 rows
inline constexpr double kPaperStartDelayMin =
    0.35;  // joint 1 of the real arm, s (the paper's text)
inline constexpr double kPaperStartDelayMax = 0.40;
// Whether `ours` is within 30 % or 0.5 degrees (whichever is larger) of `paper` (issue 20).
bool WithinTolerance(double ours, double paper);

struct ExperimentOptions {
  std::vector<int> sets = {1, 2, 3, 4, 5, 6, 7};
  double hold_before_s = 0.3;   // the arms hold the zero pose this long before the move
  double settle_after_s = 0.5;  // and run this long after the virtual profile is done
};

// The virtual arm's run of one set: per servo tick, the set-point, the virtual positions (rad) and
// the profile's done flags. Independent of the real arm, so fitting runs it once.
struct VirtualRun {
  int set = 0;
  size_t move_tick = 0;                                 // the tick the move was loaded
  std::vector<std::vector<double>> setpoint, position;  // [tick][joint]
  std::vector<std::vector<int8_t>> done;
};
VirtualRun RunVirtual(const core::RobotModel& model, int set, const ExperimentOptions& options);

// The emulated real arm's encoder-measured positions (rad), one row per tick of `virtual_run`,
// the same move loaded at the same tick. effects unset: the model's own arm (friction x 1.5, the
// emulator's old default).
std::vector<std::vector<double>> RunReal(const core::RobotModel& model,
                                         const std::optional<hardware::RealArmParams>& effects,
                                         const VirtualRun& virtual_run);

// The three streams as a data table (deg), the move as move 1 after a move 0 of holding.
logger::RunTable MakeTable(const core::RobotModel& model, const VirtualRun& virtual_run,
                           const std::vector<std::vector<double>>& real);

// Writes the run as a logger data file (the format sirupp-logger writes, docs/logging.md), plan
// config/plans/setN.plan, one row per servo tick: what `sirupp report` and `sirupp identify`
// read. Throws std::runtime_error if the file exists or cannot be written.
void WriteDataFile(const std::string& path, const core::RobotModel& model,
                   const VirtualRun& virtual_run, const std::vector<std::vector<double>>& real);

// Our Table II: one row per set and moved joint, in the paper's order.
struct TableRow {
  int set = 0;
  int joint = 0;
  double transient_deg = 0, steady_deg = 0;  // mean |virtual - real|
  double start_delay_real_s = 0, start_delay_virtual_s = 0;
};
std::vector<TableRow> TableII(const std::vector<logger::RunTable>& tables);

// How far the real arm's joints that the set does not move stray from the virtual arm's (deg, the
// largest over the run's ticks): a real arm that cannot hold its pose (a shoulder whose motor is
// too weak for gravity) strays by degrees, a sound one by hundredths.
double HoldStrayDeg(const VirtualRun& virtual_run, const std::vector<std::vector<double>>& real);

// Runs every set of `options` on both arms and returns the table; with data_dir, also writes each
// set's data file there (DATA_DIR/lab-setN.csv); with hold_stray_deg, the largest HoldStrayDeg of
// the sets there.
std::vector<TableRow> RunExperiment(const core::RobotModel& virtual_model,
                                    const core::RobotModel& real_model,
                                    const std::optional<hardware::RealArmParams>& effects,
                                    const ExperimentOptions& options,
                                    const std::string& data_dir = "",
                                    double* hold_stray_deg = nullptr);

// How our table compares with the paper's.
struct Comparison {
  int rows = 0, rows_within = 0;                        // rows with both means within tolerance
  double start_delay_min_s = 0, start_delay_max_s = 0;  // joint 1 of the real arm, over its sets
  double mean_error_deg = 0;  // mean of our transient and steady means (all rows)
  // Coupling: mean transient error of the multi-joint rows minus that of the same joints alone.
  double coupling_ours_deg = 0, coupling_paper_deg = 0;
};
Comparison Compare(const std::vector<TableRow>& ours);
// Our rows beside the paper's, as a Markdown table, with the summary lines.
std::string FormatComparison(const std::vector<TableRow>& ours, bool with_paper);

}  // namespace sirupp::lab
