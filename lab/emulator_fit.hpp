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

struct FitOptions {
  ExperimentOptions experiment;
  int max_evaluations = 150;
  // Set: the board latency is held at this value (s) instead of fitted (docs/emulator-fit.md:
  // a short latency leaves the lag to the motors, the supply and the friction).
  std::optional<double> latency_s;
  // The coupling term's weight in the cost (FitCost); 1 is the table's own balance, more asks the
  // search to keep the paper's direction of the multi-joint sets' errors (docs/emulator-fit.md).
  double coupling_weight = 1;
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
// `coupling_weight`.
double FitCost(const std::vector<TableRow>& table, double coupling_weight = 1);
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
