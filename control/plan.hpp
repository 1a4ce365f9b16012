#pragma once
// Movement plans: the plain-text files people write (docs/plan-format.md), parsed and validated
// completely against a robot model before anything moves, into a list of steps the sequencer runs:
// moves (one LOAD_TRAJ per joint, all joints of a step starting together) and waits (for every
// joint's move-done, or for a time).
//
// Every error is one core::ConfigError "NAME:LINE:COLUMN: WORD: problem" naming the bad token, the
// value and what is allowed; the first error ends the parse. Plan text in messages (the name, the
// statement, tokens) goes through core::Printable, so control characters and bytes that are not
// UTF-8 show as \xNN. A UTF-8 byte-order mark at the start of the text is skipped.

#include <cstddef>
#include <string>
#include <vector>

#include "control/servo_bank.hpp"
#include "core/robot_model.hpp"

namespace sirupp::control {

// The largest plan text accepted, in bytes (256 KiB): a plan travels whole in one ARM_PLAN
// message, and an LCM message much larger than this is easily lost on UDP. Checked by ParsePlan
// (so by `sirupp plan check/run` and by sirupp-control alike) and by ReadPlanText.
inline constexpr size_t kMaxPlanBytes = 256 * 1024;

struct PlanStep {
  enum class Kind { kMove, kWaitDone, kWaitTime };
  Kind kind = Kind::kMove;
  int line = 0;                  // 1-based line of the plan text
  std::string text;              // the line as written, without its comment (core::Printable)
  std::vector<JointMove> moves;  // kMove: one entry per joint (active = takes part), SI
  double wait_s = 0;             // kWaitTime: seconds of sim time
  // kMove with the word `avoid`: a path around the environment to this step's goals is to be
  // planned from `from` (the goals before it, the arm at rest) before the plan runs
  // (ParsePlanWithAvoid; `sirupp plan make --expand`). ParsePlan refuses such a line.
  bool avoid = false;
  std::vector<double> from;
};

struct Plan {
  std::string name;
  std::vector<PlanStep> steps;
  std::vector<double> final_goal;  // where the joints end, SI (for reports and checks)
  int moves() const;
};

// Parses `text` (named `name` in messages, e.g. the file name) for `model`. `start` holds the joint
// positions the plan starts from (SI, one per joint): `move tool` steps pick the IK solution
// nearest the joints the plan has reached, starting there.
Plan ParsePlan(const std::string& text, const std::string& name, const core::RobotModel& model,
               const std::vector<double>& start);

// ParsePlan, also accepting `move ... avoid` (allow_avoid) for the tools that expand it.
Plan ParsePlanWithAvoid(const std::string& text, const std::string& name,
                        const core::RobotModel& model, const std::vector<double>& start,
                        bool allow_avoid);

// The file's text; throws core::ConfigError naming the file if it cannot be read.
std::string ReadPlanText(const std::string& path);

// Reads the file (errors name it) and parses it with the file's path as its name.
Plan LoadPlan(const std::string& path, const core::RobotModel& model,
              const std::vector<double>& start);

// The model's home positions (what `sirupp plan check` validates from when no arm is asked).
std::vector<double> HomePositions(const core::RobotModel& model);

}  // namespace sirupp::control
