#pragma once
// Identification, the paper's "better friction model" as a lab exercise: fits a robot model's
// joint friction (static, Coulomb per direction, viscous, Stribeck speed) and armature to a real
// arm's logged data (logger data files, the emulator's or a real PUMA's), for the virtual arm that
// will run the model: sirupp-sim's ODE arm (sim::ArmWorld) under sirupp-control's virtual
// PIC-SERVOs. Two stages:
// 1. Torque regression: the motor effort at each tick is the chip's PID recomputed from the logged
//    set-point and real angles (model gains, JointDrive::EffortFromPwm as control::ServoBank uses
//    it, clamped at the joint's maximum effort as the sim clamps it); less what the arm needs
//    (inverse dynamics of the model with each armature as rotor inertia in its child link, as the
//    sim has it), it is the armature's rotor term plus friction, linear in the friction levels,
//    viscous coefficient and armature for a given Stribeck speed. Least squares over windows in
//    which the joint slides, with a line search over the Stribeck speed, three passes.
// 2. Output-error search: the virtual arm (the model's sim::ArmWorld, each joint's PicServo held
//    at the logged set-point, its PWM turned into the effort command as sirupp-control turns it)
//    follows the logged set-point; per joint a Nelder-Mead search on a log box derived from the
//    joint (box_search.hpp) lowers Table II's measure: per move the joint takes part in, the
//    mean |virtual - real| over the transient and over the steady state as logger::Analyze
//    defines them, summed (data without moves: the squared angle error). By default only the
//    movement sets' last moves count (the ones Table II measures; the rest is simulated). The
//    search starts from the best of the regression's, the model's and 20 spread values, lowers
//    the squared error on those moves first (half the budget), then Table II's measure.
// Reads the model and the tables; writes nothing itself. docs/emulator-fit.md, "Identification".

#include <limits>
#include <string>
#include <vector>

#include "core/robot_model.hpp"
#include "logger/data_file.hpp"

namespace sirupp::lab {

struct IdentifyOptions {
  std::vector<int> joints;    // 1-based joints to fit; empty: every joint the set-point moves
  int max_evaluations = 150;  // simulations of all the data (the search; 3 or less: none)
  // Simulate and fit only each table's last move, from the row it starts: the move Table II
  // measures (a movement set's plan first returns the arm to zero, then makes it).
  bool last_move_only = false;
  // The fit weighs each movement set's last move (a file a plan ran: the move Table II measures)
  // 1 and every other move (a set's return to zero, a manual part, a file without a plan) this;
  // negative: 0 when the data has movement sets, else 1. Every move is simulated all the same.
  double other_moves_weight = -1;
  // Each trial must also make the moves any movement set makes (CheckMoves: no fitted joint over
  // its servo's error limit), which the data may lack; a trial that cannot costs infinity. Off:
  // faster (one simulation of those moves less per trial), but M2 may be unable to run the sets.
  bool require_moves = true;
};

struct JointIdentification {
  int joint = 0;  // 1-based
  core::Friction friction_before, friction_after;
  double armature_before = 0, armature_after = 0;
  // Simulated vs real over the fresh samples, each weighted as its move.
  double rms_before_deg = 0, rms_after_deg = 0;
  // Table II's measure, what the search lowers: the weighted mean of the per-move transient and
  // steady-state means of |virtual - real| (deg, or mm); NaN when the data has no move the joint
  // takes part in (the search then lowers the squared error).
  double table_before = std::numeric_limits<double>::quiet_NaN();
  double table_after = std::numeric_limits<double>::quiet_NaN();
  int64_t samples = 0;
};

struct IdentifyResult {
  core::RobotModel model;  // the input model with the fitted values
  std::vector<JointIdentification> joints;
  int evaluations = 0;
};

// Throws core::ConfigError naming the table if a table has no set-point or real data, or the
// joints do not match the model; std::runtime_error naming the joint if the model's own
// simulation blows up in ODE (a trial of the search that does costs infinity instead).
IdentifyResult Identify(const core::RobotModel& model, const std::vector<logger::RunTable>& tables,
                        const IdentifyOptions& options);

// What the model's virtual arm (as the search simulates it) does following `table`'s set-point
// from where its real stream starts (else the set-point's start): a copy of the table whose real
// stream is the simulation, one sample per row. For predictions, and to make synthetic data with
// known parameters (tests).
logger::RunTable SimulateRealStream(const core::RobotModel& model, const logger::RunTable& table);

// How far one joint of a model's virtual arm falls behind its set-point in CheckMoves.
struct LagCheck {
  int joint = 0;             // 1-based
  int64_t worst_counts = 0;  // the largest |set-point - position| over the moves, encoder counts
  int64_t limit_counts = 0;  // the joint servo's error_limit (0: none)
  std::string move;          // the move it was largest in, e.g. "0 -> 90 deg"
  bool over() const { return limit_counts > 0 && worst_counts > limit_counts; }
};

// The virtual arm of `model` (as the search simulates it) making the moves any movement set makes,
// whatever a data file held: from the model's `ready` pose (when it has one) to zero, all joints
// together, then each of `joints` (1-based) alone from zero to +90 deg (a prismatic joint: the
// middle of its range, a revolute one's goal clamped into its limits) and back, then all of them
// together there and back, each at its servo's default speed and acceleration (the chip's
// trapezoid), with 0.3 s of holding after each. Per joint of `joints`, how far it falls behind.
// A joint over its error limit would stop the real virtual arm with POS_ERR: a model fitted to data
// without such moves (a return to zero against gravity) can be unable to make them.
std::vector<LagCheck> CheckMoves(const core::RobotModel& model, const std::vector<int>& joints);

// The model file's text with each fitted joint's `armature:` and `friction:` lines replaced by
// the identified values (comments and everything else kept). Throws core::ConfigError naming the
// file if a joint's entry does not have those keys on one line each.
std::string RewriteModelText(const std::string& text, const std::string& file,
                             const core::RobotModel& original, const IdentifyResult& result);

// Throws what RewriteModelText would for `joints` (1-based), before any fitting is done.
void CheckModelRewritable(const std::string& text, const std::string& file,
                          const core::RobotModel& model, const std::vector<int>& joints);

}  // namespace sirupp::lab
