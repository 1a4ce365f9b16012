#pragma once
// Inverse kinematics: the closed-form solution of PUMA-type arms (all 8 configurations) and a
// numeric damped-least-squares solver for any serial DH arm. Both report success only after forward
// kinematics of the answer reaches the target within tolerance; otherwise they say why, from a
// fixed set of reasons.
//
// Configuration labels are geometric, so they mean the same on any PUMA-type arm whatever the signs
// in its DH table (docs/kinematics.md):
//   shoulder left/right  the arm's lateral offset lies left/right of the line from the waist axis
//   to
//                        the wrist centre, seen from above (arms without offset: right = raising
//                        joint 2 lifts the wrist);
//   elbow up/down        the elbow lies above/below the line from shoulder to wrist centre;
//   wrist noflip/flip    joint 5 (wrapped to (-180, 180] degrees) is >= 0 / < 0.

#include <optional>
#include <string>
#include <vector>

#include "core/kinematics.hpp"

namespace sirupp::core {

struct IkConfiguration {
  bool shoulder_left = false;
  bool elbow_up = false;
  bool wrist_flip = false;

  // "left-up-noflip" etc.
  std::string Name() const;
  // Parses a Name(); nullopt for anything else.
  static std::optional<IkConfiguration> Parse(const std::string& name);
  bool operator==(const IkConfiguration& other) const {
    return shoulder_left == other.shoulder_left && elbow_up == other.elbow_up &&
           wrist_flip == other.wrist_flip;
  }
};

enum class IkFailure {
  kNone,                // at least one solution
  kUnreachable,         // the target is outside the arm's workspace
  kOutsideJointLimits,  // solutions exist, but none inside the joint limits
  kSingular,            // the solver stalled at a singularity short of the target
  kNoConvergence,       // the numeric solver did not reach the target from any seed
  kNotApplicable,       // the closed-form solver does not fit this arm (use the numeric one)
};
const char* IkFailureName(IkFailure failure);

struct IkSolution {
  JointVector q;                          // joint positions, rad / m, unwrapped into the limits
  std::optional<IkConfiguration> config;  // set by the closed-form solver
  PoseError error;                        // FK(q) against the target
  bool within_limits = true;
  std::vector<std::string> singularities;  // names, e.g. "wrist"; empty when regular
};

struct IkResult {
  std::vector<IkSolution> solutions;  // solutions within limits first, each group nearest first
  IkFailure failure = IkFailure::kNone;
  std::string reason;  // one line for people when failure != kNone
  bool ok() const { return failure == IkFailure::kNone; }
};

// Tolerances of "reaches the target": position (m) and rotation (rad).
struct IkTolerance {
  double position_m = 1e-9;
  double rotation_rad = 1e-9;
};

// Why the closed-form solver cannot handle `model`, or nullopt when it can: standard DH, six
// revolute joints, a1 = 0, alpha1 = +-90, alpha2 = 0, alpha3 = +-90, a spherical wrist
// (a4 = a5 = a6 = 0, d5 = 0, alpha4 = -alpha5 = +-90).
std::optional<std::string> PumaIkNotApplicable(const RobotModel& model);

// All 8 closed-form solutions for the tool pose `target` (world frame). Each is verified by forward
// kinematics; revolute joints are moved by whole turns into their limits, nearest `reference`.
// Solutions outside the limits are returned with within_limits = false after the valid ones; when
// none is inside, failure = kOutsideJointLimits.
IkResult SolvePumaIk(const RobotModel& model, const Eigen::Isometry3d& target,
                     const JointVector& reference, const IkTolerance& tolerance = {});

struct NumericIkOptions {
  IkTolerance tolerance;
  int max_iterations = 300;  // per seed
  int random_seeds = 16;  // seeds drawn inside the limits, besides the reference, home, named poses
  uint32_t random_seed = 12345;
  bool position_only = false;  // ignore orientation (for arms with fewer than 6 joints)
  bool stop_at_first = false;  // return as soon as one solution is found
};

// Damped least squares (Levenberg-Marquardt damping) from several seeds, joint limits enforced by
// projection. Distinct solutions are returned, nearest `reference` first.
IkResult SolveNumericIk(const RobotModel& model, const Eigen::Isometry3d& target,
                        const JointVector& reference, const NumericIkOptions& options = {});

// Which solver an IK request takes, the one choice of `sirupp ik` and the Python module's
// Model.ikine: the closed form when it applies to the arm (PumaIkNotApplicable) and neither the
// numeric solver nor a position-only target is asked for; the numeric solver otherwise.
struct IkRequest {
  bool numeric = false;        // the numeric solver even where the closed form applies
  bool position_only = false;  // the orientation left free (numeric solver)
};
struct IkSolverChoice {
  bool closed_form = false;
  // Why not the closed form, for messages ("" when closed_form): "numeric solver asked for",
  // "position-only target", or PumaIkNotApplicable's reason.
  std::string not_closed_form;
};
IkSolverChoice ChooseIkSolver(const RobotModel& model, const IkRequest& request);
// Solves with ChooseIkSolver's choice: SolvePumaIk, or SolveNumericIk from `reference`.
IkResult SolveIk(const RobotModel& model, const Eigen::Isometry3d& target,
                 const JointVector& reference, const IkRequest& request);

// Named singularities of the configuration q. PUMA-type arms: "wrist" (joint 5 at 0 or 180 deg),
// "elbow" (arm fully stretched or folded), "shoulder" (wrist centre on the cylinder where the two
// shoulder solutions meet, or on the waist axis). Other arms: "rank-deficient Jacobian".
std::vector<std::string> Singularities(const RobotModel& model, const JointVector& q,
                                       double tolerance = 1e-6);

// Picks the solution nearest `reference` among those within limits (nullptr if none).
const IkSolution* NearestSolution(const IkResult& result, const JointVector& reference);

}  // namespace sirupp::core
