#include "core/inverse_kinematics.hpp"

#include <Eigen/Cholesky>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <random>

#include "core/errors.hpp"

namespace sirupp::core {

namespace {

constexpr double kAngleEps = 1e-12;

bool Near(double value, double target, double eps = 1e-9) { return std::abs(value - target) < eps; }

double WrapPi(double angle) {
  angle = std::remainder(angle, 2 * M_PI);
  return angle <= -M_PI ? angle + 2 * M_PI : angle;
}

double Distance(const JointVector& a, const JointVector& b) { return (a - b).norm(); }

// Moves each revolute joint by whole turns to the value nearest the reference that lies inside its
// limits; returns false (keeping the nearest-to-reference value) when no turn fits.
bool UnwrapIntoLimits(const RobotModel& model, const JointVector& reference, JointVector& q) {
  bool inside = true;
  for (int i = 0; i < q.size(); ++i) {
    const Joint& joint = model.joints[static_cast<size_t>(i)];
    if (joint.type != JointType::kRevolute) {
      inside = inside && q[i] >= joint.position_min && q[i] <= joint.position_max;
      continue;
    }
    double best = q[i] + 2 * M_PI * std::round((reference[i] - q[i]) / (2 * M_PI));
    bool found = false;
    const double first =
        q[i] + 2 * M_PI * std::ceil((joint.position_min - q[i]) / (2 * M_PI) - 1e-12);
    for (double candidate = first; candidate <= joint.position_max + 1e-12; candidate += 2 * M_PI) {
      const double clamped = std::clamp(candidate, joint.position_min, joint.position_max);
      if (!found || std::abs(clamped - reference[i]) < std::abs(best - reference[i]))
        best = clamped;
      found = true;
    }
    inside = inside && found;
    q[i] = best;
  }
  return inside;
}

void SortSolutions(std::vector<IkSolution>& solutions, const JointVector& reference) {
  std::stable_sort(solutions.begin(), solutions.end(),
                   [&](const IkSolution& a, const IkSolution& b) {
                     if (a.within_limits != b.within_limits) return a.within_limits;
                     return Distance(a.q, reference) < Distance(b.q, reference);
                   });
}

bool Reaches(const PoseError& error, const IkTolerance& tolerance, bool position_only = false) {
  return error.position_m <= tolerance.position_m &&
         (position_only || error.rotation_rad <= tolerance.rotation_rad);
}

// Geometry shared by the closed-form solver and the singularity names.
struct PumaGeometry {
  double s1;       // sin(alpha1) = +-1
  double lateral;  // d2 + d3: offset of the wrist centre along the joint-2 axis
  double a2;
  double l3;    // distance elbow axis -> wrist centre in the arm plane
  double beta;  // angle of that vector at theta3 = 0
  double d1;
};

PumaGeometry GeometryOf(const RobotModel& model) {
  const auto& j = model.joints;
  PumaGeometry g;
  g.s1 = std::sin(j[0].dh.alpha_rad);
  g.lateral = j[1].dh.d_m + j[2].dh.d_m;
  g.a2 = j[1].dh.a_m;
  const double s3 = std::sin(j[2].dh.alpha_rad);
  g.l3 = std::hypot(j[2].dh.a_m, j[3].dh.d_m);
  g.beta = std::atan2(-s3 * j[3].dh.d_m, j[2].dh.a_m);
  g.d1 = j[0].dh.d_m;
  return g;
}

// Tool target -> pose of DH frame 6 in frame 0.
Eigen::Isometry3d Frame6InBase(const RobotModel& model, const Eigen::Isometry3d& target) {
  return model.base.ToIsometry().inverse() * target * model.tool.ToIsometry().inverse();
}

Eigen::Vector3d WristCentreInBase(const RobotModel& model, const Eigen::Isometry3d& frame6) {
  const Joint& j6 = model.joints[5];
  const Eigen::Vector3d z5 = frame6.linear() *
                             Eigen::AngleAxisd(-j6.dh.alpha_rad, Eigen::Vector3d::UnitX()) *
                             Eigen::Vector3d::UnitZ();
  return frame6.translation() - j6.dh.d_m * z5;
}

// Named singularities of a PUMA-type arm, given the wrist centre in the base frame.
std::vector<std::string> PumaSingularities(const RobotModel& model, const PumaGeometry& g,
                                           const JointVector& q,
                                           const Eigen::Vector3d& wrist_in_base, double tolerance) {
  const auto& j = model.joints;
  std::vector<std::string> names;
  if (std::abs(std::sin(q[4] + j[4].dh.theta_rad)) < tolerance) names.push_back("wrist");
  if (std::abs(std::sin(q[2] + j[2].dh.theta_rad + g.beta)) < tolerance) names.push_back("elbow");
  const double r = std::hypot(wrist_in_base.x(), wrist_in_base.y());
  if (std::sqrt(std::max(0.0, r * r - g.lateral * g.lateral)) < tolerance)
    names.push_back("shoulder");
  return names;
}

}  // namespace

std::string IkConfiguration::Name() const {
  return std::string(shoulder_left ? "left" : "right") + "-" + (elbow_up ? "up" : "down") + "-" +
         (wrist_flip ? "flip" : "noflip");
}

std::optional<IkConfiguration> IkConfiguration::Parse(const std::string& name) {
  for (int bits = 0; bits < 8; ++bits) {
    IkConfiguration config{(bits & 1) != 0, (bits & 2) != 0, (bits & 4) != 0};
    if (config.Name() == name) return config;
  }
  return std::nullopt;
}

const char* IkFailureName(IkFailure failure) {
  switch (failure) {
    case IkFailure::kNone:
      return "ok";
    case IkFailure::kUnreachable:
      return "unreachable";
    case IkFailure::kOutsideJointLimits:
      return "outside joint limits";
    case IkFailure::kSingular:
      return "singular";
    case IkFailure::kNoConvergence:
      return "no convergence";
    case IkFailure::kNotApplicable:
      return "not applicable";
  }
  return "?";
}

std::optional<std::string> PumaIkNotApplicable(const RobotModel& model) {
  if (model.dh_convention != DhConvention::kStandard) return "it uses modified DH";
  if (model.num_joints() != 6)
    return "it has " + std::to_string(model.num_joints()) + " joints, not 6";
  for (const Joint& joint : model.joints) {
    if (joint.type != JointType::kRevolute) return "joint " + joint.name + " is not revolute";
  }
  const auto& j = model.joints;
  auto quarter = [](double alpha) { return Near(std::abs(std::sin(alpha)), 1); };
  if (!Near(j[0].dh.a_m, 0) || !quarter(j[0].dh.alpha_rad))
    return "joint 1 needs a1 = 0, alpha1 = +-90";
  if (!Near(std::cos(j[1].dh.alpha_rad), 1) || Near(j[1].dh.a_m, 0)) {
    return "joints 2 and 3 need parallel axes (alpha2 = 0) and a2 != 0";
  }
  if (!quarter(j[2].dh.alpha_rad)) return "joint 3 needs alpha3 = +-90";
  if (!Near(j[3].dh.a_m, 0) || !Near(j[4].dh.a_m, 0) || !Near(j[5].dh.a_m, 0) ||
      !Near(j[4].dh.d_m, 0) || !quarter(j[3].dh.alpha_rad) ||
      !Near(j[3].dh.alpha_rad, -j[4].dh.alpha_rad)) {
    return "the wrist is not spherical (needs a4 = a5 = a6 = 0, d5 = 0, alpha4 = -alpha5 = +-90)";
  }
  if (Near(std::hypot(j[2].dh.a_m, j[3].dh.d_m), 0)) return "the forearm has zero length";
  return std::nullopt;
}

namespace {

// The closed-form solver for one target: the two waist branches, each with two elbow and two
// wrist branches. Every candidate is checked by forward kinematics before it is kept.
class PumaSolver {
 public:
  PumaSolver(const RobotModel& model, const Eigen::Isometry3d& target, const JointVector& reference,
             const IkTolerance& tolerance)
      : model_(model),
        j_(model.joints),
        target_(target),
        reference_(reference),
        tolerance_(tolerance),
        chain_(model),
        g_(GeometryOf(model)),
        frame6_(Frame6InBase(model, target)),
        wrist_centre_(WristCentreInBase(model, frame6_)) {}

  IkResult Solve() {
    const Eigen::Vector3d p = wrist_centre_ - Eigen::Vector3d(0, 0, g_.d1);
    // Joint 1: the wrist centre's offset along z1 must equal the arm's lateral offset.
    const double k = g_.lateral / g_.s1;
    const double r = std::hypot(p.x(), p.y());
    if (r < std::abs(k) - 1e-12) {
      result_.failure = IkFailure::kUnreachable;
      result_.reason = "the wrist centre is " + FormatApprox(r) +
                       " m from the waist axis, closer than the arm's lateral offset " +
                       FormatApprox(std::abs(k)) + " m";
      return result_;
    }
    // On the waist axis (possible only without lateral offset) joint 1 is free: keep the
    // reference.
    const double phi =
        r > kAngleEps ? std::atan2(p.y(), p.x()) : reference_[0] + j_[0].dh.theta_rad;
    const double offset_angle = std::asin(std::clamp(k / std::max(r, kAngleEps), -1.0, 1.0));
    const double theta1_options[2] = {phi + offset_angle, phi + M_PI - offset_angle};
    // Direction from the waist axis to the wrist centre, seen from above.
    reach_ = r > kAngleEps ? Eigen::Vector3d(p.x() / r, p.y() / r, 0)
                           : Eigen::Vector3d(std::cos(phi), std::sin(phi), 0);
    for (double theta1 : theta1_options) {
      if (!SolveWaistBranch(theta1)) return result_;
    }
    SortSolutions(result_.solutions, reference_);
    if (result_.solutions.empty()) {
      result_.failure = IkFailure::kNoConvergence;
      result_.reason = "no closed-form branch reproduced the target within tolerance";
    } else if (!result_.solutions.front().within_limits) {
      result_.failure = IkFailure::kOutsideJointLimits;
      result_.reason = std::to_string(result_.solutions.size()) +
                       " solutions reach the target, but each puts a joint outside its limits";
    }
    return result_;
  }

 private:
  // Joint 1's frame for one waist branch and the labels that do not depend on the elbow.
  struct ArmPlane {
    double theta1;
    Eigen::Matrix3d r01;
    Eigen::Vector3d p1;  // the wrist centre in frame 1
    bool shoulder_left;
    Eigen::Vector2d side;  // the elbow-up side of the shoulder-wrist line, in frame 1's plane
  };

  ArmPlane PlaneOf(double theta1) const {
    const Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
    // Wrist centre in frame 1: the planar two-link problem of joints 2 and 3.
    const Eigen::Isometry3d a1 =
        DhTransform(DhConvention::kStandard, j_[0], theta1 - j_[0].dh.theta_rad);
    ArmPlane plane;
    plane.theta1 = theta1;
    plane.r01 = a1.linear();
    plane.p1 = plane.r01.transpose() * (wrist_centre_ - a1.translation());
    const Eigen::Vector3d z1 = plane.r01.col(2);
    // Shoulder label (see the header): the side of the reach line the lateral offset lies on.
    plane.shoulder_left = std::abs(g_.lateral) > 1e-9
                              ? up.cross(reach_).dot(g_.lateral * z1) > 0
                              : !(z1.cross(wrist_centre_ - a1.translation()).dot(up) > 0);
    // Elbow label, in frame 1's plane: the side of the shoulder-wrist line that points up (or,
    // for a vertical line, away from the waist axis).
    plane.side = Eigen::Vector2d(-plane.p1.y(), plane.p1.x());
    const Eigen::Vector3d up_in_1 = plane.r01.transpose() * up;
    const Eigen::Vector3d reach_in_1 = plane.r01.transpose() * reach_;
    const double upward = plane.side.dot(up_in_1.head<2>());
    if (std::abs(upward) > 1e-9 * plane.side.norm()) {
      if (upward < 0) plane.side = -plane.side;
    } else if (plane.side.dot(reach_in_1.head<2>()) < 0) {
      plane.side = -plane.side;
    }
    return plane;
  }

  // Both elbow branches of one waist branch; false (with the failure set) when the wrist centre
  // is out of the arm's reach.
  bool SolveWaistBranch(double theta1) {
    const ArmPlane plane = PlaneOf(theta1);
    const Eigen::Vector3d& p1 = plane.p1;
    const double reach2 = p1.x() * p1.x() + p1.y() * p1.y();
    double cos_elbow = (reach2 - g_.a2 * g_.a2 - g_.l3 * g_.l3) / (2 * g_.a2 * g_.l3);
    if (std::abs(cos_elbow) > 1 + 1e-12) {
      result_.failure = IkFailure::kUnreachable;
      result_.reason = "the wrist centre is " + FormatApprox(std::sqrt(reach2)) +
                       " m from the shoulder in the arm's plane; the arm reaches " +
                       FormatApprox(std::abs(g_.a2 - g_.l3)) + " to " +
                       FormatApprox(g_.a2 + g_.l3) + " m";
      return false;
    }
    cos_elbow = std::clamp(cos_elbow, -1.0, 1.0);
    for (double elbow_sign : {1.0, -1.0}) {
      const double gamma = elbow_sign * std::acos(cos_elbow);  // theta3 + beta
      const double theta3 = gamma - g_.beta;
      const double theta2 = std::atan2(p1.y(), p1.x()) -
                            std::atan2(g_.l3 * std::sin(gamma), g_.a2 + g_.l3 * std::cos(gamma));
      const bool elbow_up = Eigen::Vector2d(std::cos(theta2), std::sin(theta2)).dot(plane.side) > 0;
      SolveWristBranches(plane, theta2, theta3, elbow_up);
    }
    return true;
  }

  // Both wrist branches for a given arm (joints 1 to 3).
  void SolveWristBranches(const ArmPlane& plane, double theta2, double theta3, bool elbow_up) {
    JointVector q = JointVector::Zero(6);
    q[0] = plane.theta1 - j_[0].dh.theta_rad;
    q[1] = theta2 - j_[1].dh.theta_rad;
    q[2] = theta3 - j_[2].dh.theta_rad;
    // Wrist: R36 = Rz(t4) Rx(a4) Rz(t5) Rx(-a4) Rz(t6) Rx(a6) = Rz(t4) Ry(-s4 t5) Rz(t6) Rx(a6),
    // with R03 = R01 Rz(theta2 + theta3) Rx(alpha3) since alpha2 = 0.
    const Eigen::Matrix3d r03 = plane.r01 *
                                Eigen::AngleAxisd(theta2 + theta3, Eigen::Vector3d::UnitZ()) *
                                Eigen::AngleAxisd(j_[2].dh.alpha_rad, Eigen::Vector3d::UnitX());
    const Eigen::Matrix3d w = r03.transpose() * frame6_.linear() *
                              Eigen::AngleAxisd(-j_[5].dh.alpha_rad, Eigen::Vector3d::UnitX());
    const double s4 = std::sin(j_[3].dh.alpha_rad);
    const double sin_b = std::hypot(w(0, 2), w(1, 2));
    for (double wrist_sign : {1.0, -1.0}) {
      double t4, b, t6;
      if (sin_b > 1e-12) {
        b = wrist_sign * std::atan2(sin_b, w(2, 2));
        t4 = std::atan2(wrist_sign * w(1, 2), wrist_sign * w(0, 2));
        t6 = std::atan2(wrist_sign * w(2, 1), -wrist_sign * w(2, 0));
      } else {
        // Wrist singular: only t4 + t6 (b = 0) or t4 - t6 (b = pi) is fixed; keep t4 at the
        // reference and give the rest to t6. The second branch is the same pose with t4 + pi.
        b = w(2, 2) > 0 ? 0.0 : M_PI;
        t4 = reference_[3] + j_[3].dh.theta_rad + (wrist_sign > 0 ? 0.0 : M_PI);
        const double sum = std::atan2(w(1, 0), w(0, 0));
        t6 = b == 0.0 ? sum - t4 : t4 - std::atan2(-w(1, 0), -w(0, 0));
        if (wrist_sign < 0) b = -b;
      }
      q[3] = t4 - j_[3].dh.theta_rad;
      q[4] = -s4 * b - j_[4].dh.theta_rad;
      q[5] = t6 - j_[5].dh.theta_rad;
      Keep(q, plane.shoulder_left, elbow_up);
    }
  }

  // Wraps and unwraps a candidate into the limits and keeps it when FK confirms it.
  void Keep(const JointVector& q, bool shoulder_left, bool elbow_up) {
    IkSolution solution;
    solution.q = q;
    for (int i = 0; i < 6; ++i) solution.q[i] = WrapPi(solution.q[i]);
    solution.within_limits = UnwrapIntoLimits(model_, reference_, solution.q);
    solution.error = ComparePoses(chain_.ToolPose(solution.q), target_);
    if (!Reaches(solution.error, tolerance_)) return;  // never claim what FK does not confirm
    solution.config =
        IkConfiguration{shoulder_left, elbow_up, WrapPi(solution.q[4] + j_[4].dh.theta_rad) < 0};
    solution.singularities = PumaSingularities(model_, g_, solution.q, wrist_centre_, 1e-6);
    result_.solutions.push_back(solution);
  }

  const RobotModel& model_;
  const std::vector<Joint>& j_;
  const Eigen::Isometry3d& target_;
  const JointVector& reference_;
  const IkTolerance& tolerance_;
  const KinematicChain chain_;
  const PumaGeometry g_;
  const Eigen::Isometry3d frame6_;
  const Eigen::Vector3d wrist_centre_;
  Eigen::Vector3d reach_ = Eigen::Vector3d::Zero();
  IkResult result_;
};

}  // namespace

IkResult SolvePumaIk(const RobotModel& model, const Eigen::Isometry3d& target,
                     const JointVector& reference, const IkTolerance& tolerance) {
  if (const auto why = PumaIkNotApplicable(model)) {
    IkResult result;
    result.failure = IkFailure::kNotApplicable;
    result.reason = "the closed-form solver does not fit " + model.name + ": " + *why;
    return result;
  }
  return PumaSolver(model, target, reference, tolerance).Solve();
}

namespace {

// One damped-least-squares descent from `seed`. Returns the end point and its error.
struct Descent {
  JointVector q;
  PoseError error;
  bool converged = false;
};

Eigen::Matrix<double, 6, 1> TaskError(const Eigen::Isometry3d& current,
                                      const Eigen::Isometry3d& target) {
  Eigen::Matrix<double, 6, 1> e;
  e.head<3>() = target.translation() - current.translation();
  const Eigen::AngleAxisd rotation(target.linear() * current.linear().transpose());
  e.tail<3>() = rotation.angle() * rotation.axis();
  return e;
}

Descent Descend(const RobotModel& model, const KinematicChain& chain,
                const Eigen::Isometry3d& target, JointVector q, const NumericIkOptions& options,
                bool enforce_limits) {
  const int n = model.num_joints();
  const int rows = options.position_only ? 3 : 6;
  auto clamp = [&](JointVector& v) {
    if (!enforce_limits) return;
    for (int i = 0; i < n; ++i) {
      const Joint& joint = model.joints[static_cast<size_t>(i)];
      v[i] = std::clamp(v[i], joint.position_min, joint.position_max);
    }
  };
  clamp(q);
  Eigen::Isometry3d pose = chain.ToolPose(q);
  Eigen::VectorXd e = TaskError(pose, target).head(rows);
  double cost = e.squaredNorm();
  double lambda = 1e-3;
  Descent result;
  for (int iteration = 0; iteration < options.max_iterations; ++iteration) {
    result.error = ComparePoses(pose, target);
    if (Reaches(result.error, options.tolerance, options.position_only)) {
      result.converged = true;
      break;
    }
    const Eigen::MatrixXd jac = chain.GeometricJacobian(q).topRows(rows);
    const Eigen::MatrixXd jjt = jac * jac.transpose();
    bool improved = false;
    // Levenberg-Marquardt: raise the damping until a step lowers the error. The damping keeps steps
    // bounded near singularities instead of letting them blow up.
    for (int attempt = 0; attempt < 40 && !improved; ++attempt) {
      const Eigen::MatrixXd damped = jjt + lambda * lambda * Eigen::MatrixXd::Identity(rows, rows);
      JointVector step = jac.transpose() * damped.ldlt().solve(e);
      JointVector next = q + step;
      clamp(next);
      const Eigen::Isometry3d next_pose = chain.ToolPose(next);
      const Eigen::VectorXd next_e = TaskError(next_pose, target).head(rows);
      if (next_e.squaredNorm() < cost) {
        q = next;
        pose = next_pose;
        e = next_e;
        cost = e.squaredNorm();
        lambda = std::max(lambda / 3, 1e-9);
        improved = true;
      } else {
        lambda = std::min(lambda * 4, 1e6);
      }
    }
    if (!improved) break;  // stalled: a local minimum, a limit, or a singularity
  }
  result.q = q;
  result.error = ComparePoses(pose, target);
  result.converged = Reaches(result.error, options.tolerance, options.position_only);
  return result;
}

std::vector<JointVector> Seeds(const RobotModel& model, const JointVector& reference,
                               const NumericIkOptions& options) {
  const int n = model.num_joints();
  std::vector<JointVector> seeds{reference};
  JointVector home(n), middle(n);
  for (int i = 0; i < n; ++i) {
    const Joint& joint = model.joints[static_cast<size_t>(i)];
    home[i] = joint.home;
    middle[i] = (joint.position_min + joint.position_max) / 2;
  }
  seeds.push_back(home);
  seeds.push_back(middle);
  for (const NamedPose& pose : model.named_poses) seeds.push_back(ToJointVector(pose.position));
  std::mt19937 random(options.random_seed);
  for (int s = 0; s < options.random_seeds; ++s) {
    JointVector q(n);
    for (int i = 0; i < n; ++i) {
      const Joint& joint = model.joints[static_cast<size_t>(i)];
      // Revolute joints with huge ranges: draw within one turn around the middle.
      const double span = std::min(joint.position_max - joint.position_min,
                                   joint.type == JointType::kRevolute ? 2 * M_PI : 1e9);
      const double low = std::max(joint.position_min, middle[i] - span / 2);
      q[i] = std::uniform_real_distribution<double>(low, low + span)(random);
    }
    seeds.push_back(q);
  }
  return seeds;
}

// An upper bound of the distance from joint 1's axis origin the tool can reach.
double ReachBound(const RobotModel& model) {
  double reach = model.tool.position_m.norm();
  for (const Joint& joint : model.joints) {
    reach += std::abs(joint.dh.a_m) + std::abs(joint.dh.d_m);
    if (joint.type == JointType::kPrismatic) {
      reach += std::max(std::abs(joint.position_min), std::abs(joint.position_max));
    }
  }
  return reach;
}

}  // namespace

IkResult SolveNumericIk(const RobotModel& model, const Eigen::Isometry3d& target,
                        const JointVector& reference, const NumericIkOptions& options) {
  IkResult result;
  const Eigen::Vector3d local = model.base.ToIsometry().inverse() * target.translation();
  if (local.norm() > ReachBound(model) + 1e-9) {
    result.failure = IkFailure::kUnreachable;
    result.reason = "the target is " + FormatApprox(local.norm()) + " m from the base; " +
                    model.name + " reaches at most " + FormatApprox(ReachBound(model)) + " m";
    return result;
  }
  const KinematicChain chain(model);
  Descent best;
  best.error.position_m = best.error.rotation_rad = INFINITY;
  const std::vector<JointVector> seeds = Seeds(model, reference, options);
  for (const JointVector& seed : seeds) {
    Descent descent = Descend(model, chain, target, seed, options, /*enforce_limits=*/true);
    if (descent.error.position_m + descent.error.rotation_rad <
        best.error.position_m + best.error.rotation_rad) {
      best = descent;
    }
    if (!descent.converged) continue;
    const bool repeated =
        std::any_of(result.solutions.begin(), result.solutions.end(),
                    [&](const IkSolution& s) { return Distance(s.q, descent.q) < 1e-6; });
    if (repeated) continue;
    IkSolution solution;
    solution.q = descent.q;
    solution.error = descent.error;
    solution.singularities = Singularities(model, descent.q);
    result.solutions.push_back(solution);
    if (options.stop_at_first) break;
  }
  SortSolutions(result.solutions, reference);
  if (!result.solutions.empty()) return result;

  // No solution inside the limits: tell apart "only outside the limits" from the rest.
  for (const JointVector& seed : seeds) {
    const Descent free = Descend(model, chain, target, seed, options, /*enforce_limits=*/false);
    if (free.converged) {
      result.failure = IkFailure::kOutsideJointLimits;
      result.reason = "the target is reachable only with joints outside their limits";
      return result;
    }
  }
  const Eigen::MatrixXd jac =
      chain.GeometricJacobian(best.q).topRows(options.position_only ? 3 : 6);
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(jac);
  const double smallest = svd.singularValues()(svd.singularValues().size() - 1);
  if (smallest < 1e-4) {
    result.failure = IkFailure::kSingular;
    result.reason = "the solver stalled at a singular configuration (smallest singular value " +
                    FormatApprox(smallest) + "), " + FormatApprox(best.error.position_m) +
                    " m and " + FormatApprox(best.error.rotation_rad) + " rad from the target";
  } else {
    result.failure = IkFailure::kNoConvergence;
    result.reason = "no seed reached the target; the closest ended " +
                    FormatApprox(best.error.position_m) + " m and " +
                    FormatApprox(best.error.rotation_rad) + " rad away";
  }
  return result;
}

IkSolverChoice ChooseIkSolver(const RobotModel& model, const IkRequest& request) {
  IkSolverChoice choice;
  if (request.numeric) {
    choice.not_closed_form = "numeric solver asked for";
  } else if (request.position_only) {
    choice.not_closed_form = "position-only target";
  } else if (const std::optional<std::string> why = PumaIkNotApplicable(model)) {
    choice.not_closed_form = *why;
  } else {
    choice.closed_form = true;
  }
  return choice;
}

IkResult SolveIk(const RobotModel& model, const Eigen::Isometry3d& target,
                 const JointVector& reference, const IkRequest& request) {
  if (ChooseIkSolver(model, request).closed_form) return SolvePumaIk(model, target, reference);
  NumericIkOptions options;
  options.position_only = request.position_only;
  return SolveNumericIk(model, target, reference, options);
}

std::vector<std::string> Singularities(const RobotModel& model, const JointVector& q,
                                       double tolerance) {
  const KinematicChain chain(model);
  if (!PumaIkNotApplicable(model)) {
    const ForwardResult fk = chain.Forward(q);
    const Eigen::Vector3d wrist = model.base.ToIsometry().inverse() * fk.frames[4].translation();
    return PumaSingularities(model, GeometryOf(model), q, wrist, tolerance);
  }
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(chain.GeometricJacobian(q));
  const Eigen::VectorXd values = svd.singularValues();
  const Eigen::Index rank_wanted = std::min<Eigen::Index>(6, q.size());
  if (values(rank_wanted - 1) < tolerance) return {"rank-deficient Jacobian"};
  return {};
}

const IkSolution* NearestSolution(const IkResult& result, const JointVector& reference) {
  const IkSolution* nearest = nullptr;
  for (const IkSolution& solution : result.solutions) {
    if (!solution.within_limits) continue;
    if (!nearest || Distance(solution.q, reference) < Distance(nearest->q, reference))
      nearest = &solution;
  }
  return nearest;
}

}  // namespace sirupp::core
