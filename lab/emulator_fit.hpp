#pragma once
// Fits the emulated real arm's effects (hardware/real_arm.hpp) to the SIRUPP paper's Table II and
// joint 1's start delay: Nelder-Mead on the unit box of the parameters that shape the paper's
// numbers (board latency unless held, supply voltage and resistance, and per arm joint the motor's
// torque constant and resistance, the friction level, the Coulomb-to-static ratio and the viscous
// friction), restarted around
// the best point until the budget is spent. The ranges are the file's narrowed to a plausible
// PUMA 260 motor (torque constant 0.02-0.08 N*m/A). Each evaluation runs the seven sets on the
// emulated arm against the virtual arm's runs (made once). Reads the models and a starting file;
// writes nothing itself.

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "hardware/real_arm.hpp"
#include "lab/experiment.hpp"

namespace sirupp::lab {

// Means of the paper's Table II that the fit's cost leaves out: one row's transient, steady state
// or both. They are still printed and counted in "rows within"; only the search ignores them
// (docs/emulator-fit.md, "Rows left out").
struct LeftOutMean {
  int set = 0;    // 1..7
  int joint = 0;  // ours, 1-based, a row of PaperTable()
  bool transient = false, steady = false;
};
// "V-1,V-3:transient" (a comma list of rows ROMAN-JOINT or N-JOINT, each optionally with
// :transient or :steady; "none" for the empty list). Throws std::invalid_argument naming the value
// and what is allowed.
std::vector<LeftOutMean> ParseLeftOutMeans(const std::string& text);
// "V-1 steady, V-3 transient" ("none" when empty).
std::string FormatLeftOutMeans(const std::vector<LeftOutMean>& left_out);
// The paper's means that contradict its other rows for any arm that behaves the same in every set
// (docs/emulator-fit.md): V-1 and VI-2's steady states (5.2 and 5.3 deg, against 0.2-1.9 in every
// other set moving those joints) and V-3 and VI-3's transients (1.8 and 0.3 deg, against 4.9 alone
// and 5.5 with both other joints). FitOptions leaves them out by default.
const std::vector<LeftOutMean>& ContradictoryMeans();

struct FitOptions {
  ExperimentOptions experiment;
  int max_evaluations = 150;
  // Set: the board latency is held at this value (s) instead of fitted (docs/emulator-fit.md:
  // a short latency leaves the lag to the motors, the supply and the friction).
  std::optional<double> latency_s;
  // The coupling term's weight in the cost (FitCost); 1 is the table's own balance, more asks the
  // search to keep the paper's direction of the multi-joint sets' errors (docs/emulator-fit.md).
  double coupling_weight = 1;
  // The paper's means the cost leaves out (FitCost).
  std::vector<LeftOutMean> left_out = ContradictoryMeans();
  // Told after each accepted step: evaluation count, cost, the parameter changed.
  std::function<void(int, double, const std::string&)> progress;
};

struct FitResult {
  hardware::RealArmParams params;
  std::vector<TableRow> table;  // with the fitted parameters
  double cost_before = 0, cost_after = 0;
  double hold_stray_deg = 0;  // with the fitted parameters: the largest HoldStrayDeg of the sets
  int evaluations = 0;
  // The fitted parameters, each as "name value (range min..max)".
  std::vector<std::string> fitted;
};

// The fit's cost of a table: robust squared misfits (saturating, so a row no physical arm can
// match does not pull the others) of the transient and steady means in units of the tolerance
// (30 % or 0.5 deg), plus joint 1's start delay against 0.375 +- 0.05 s, plus the coupling (sets
// IV and VII against the joints alone) against the paper's in units of 0.25 deg, times
// `coupling_weight`. The means in `left_out` count nothing, and the coupling leaves out each pair
// whose multi-joint or alone transient is left out; joint 1's start delay (the paper's text, not
// its table) counts in every set.
double FitCost(const std::vector<TableRow>& table, double coupling_weight = 1,
               const std::vector<LeftOutMean>& left_out = {});
// The fit's penalty for an arm that does not hold the joints a set leaves still (HoldStrayDeg of
// each run, in units of 0.5 deg, robust like the rest): added to FitCost for each run.
double HoldCost(double hold_stray_deg);

// How far each arm joint (1-3) of `arm` can drive itself at the model's top speed
// (joint.velocity_max) against its own arm: the torque its motor gives there at full PWM from the
// supply through its source resistance (back-EMF and the amplifier's current limit), over its
// Coulomb (the larger way)
// and viscous friction at that speed plus its largest gravity load (the model's, over the shoulder
// and elbow's range). The fit keeps every joint at kMinSpeedMargin or more: a real PUMA lifts its
// arm at its rated speed, while an arm whose friction and gravity eat its motor follows the paper's
// 45 deg/s sets but trips its position error lifting the forearm or on a faster move.
std::vector<double> SpeedMargins(const hardware::RealArmParams& arm, const core::RobotModel& model);
inline constexpr double kMinSpeedMargin = 1.0;

FitResult FitEmulator(const core::RobotModel& virtual_model, const core::RobotModel& real_model,
                      const hardware::RealArmParams& start, const FitOptions& options);

}  // namespace sirupp::lab
