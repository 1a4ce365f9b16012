#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <random>
#include <set>

#include "core/inverse_kinematics.hpp"
#include "core/model_loader.hpp"

namespace sirupp::core {
namespace {

constexpr double kDeg = M_PI / 180;

JointVector RandomJoints(const RobotModel& model, std::mt19937& random, double margin = 0) {
  JointVector q(model.num_joints());
  for (int i = 0; i < q.size(); ++i) {
    const Joint& joint = model.joints[static_cast<size_t>(i)];
    q[i] = std::uniform_real_distribution<double>(joint.position_min + margin,
                                                  joint.position_max - margin)(random);
  }
  return q;
}

// Same joint positions up to whole turns of revolute joints.
bool SameUpToTurns(const RobotModel& model, const JointVector& a, const JointVector& b,
                   double eps) {
  for (int i = 0; i < a.size(); ++i) {
    double d = a[i] - b[i];
    if (model.joints[static_cast<size_t>(i)].type == JointType::kRevolute) {
      d = std::remainder(d, 2 * M_PI);
    }
    if (std::abs(d) > eps) return false;
  }
  return true;
}

// The configuration of q by the geometric definitions in inverse_kinematics.hpp, measured on the
// frames that forward kinematics gives (independent of the solver's own bookkeeping).
IkConfiguration MeasuredConfiguration(const RobotModel& model, const JointVector& q) {
  const ForwardResult fk = ForwardKinematics(model, q);
  const Eigen::Vector3d up = Eigen::Vector3d::UnitZ();  // base at identity in these tests
  const Eigen::Vector3d shoulder = fk.frames[1].translation();
  const Eigen::Vector3d z1 = fk.frames[1].linear().col(2);
  const Eigen::Vector3d elbow = fk.frames[2].translation();
  const Eigen::Vector3d wrist = fk.frames[4].translation();
  const Eigen::Vector3d reach = Eigen::Vector3d(wrist.x(), wrist.y(), 0).normalized();
  // The lateral offset of the arm: the wrist centre's component along z1, from the waist axis.
  const Eigen::Vector3d offset = wrist.dot(z1) * z1;
  IkConfiguration config;
  config.shoulder_left = up.cross(reach).dot(offset) > 0;
  Eigen::Vector3d side = z1.cross(wrist - shoulder);
  if (side.dot(up) < 0) side = -side;
  config.elbow_up = (elbow - shoulder).dot(side) > 0;
  config.wrist_flip = std::remainder(q[4], 2 * M_PI) < 0;
  return config;
}

class PumaIk : public ::testing::Test {
 protected:
  RobotModel puma = LoadRobotModel("config/robots/puma260.yaml");
};

TEST_F(PumaIk, AppliesToThePumaButNotToOtherArms) {
  EXPECT_FALSE(PumaIkNotApplicable(puma));
  EXPECT_EQ(*PumaIkNotApplicable(LoadRobotModel("config/robots/planar3.yaml")),
            "it uses modified DH");
  EXPECT_EQ(*PumaIkNotApplicable(LoadRobotModel("config/robots/stanford.yaml")),
            "joint boom is not revolute");
  const IkResult result = SolvePumaIk(LoadRobotModel("config/robots/stanford.yaml"),
                                      Eigen::Isometry3d::Identity(), JointVector::Zero(6));
  EXPECT_EQ(result.failure, IkFailure::kNotApplicable);
}

TEST_F(PumaIk, OneSolverChoiceForEveryCaller) {
  // The closed form where it applies and nothing else is asked; the numeric solver, with the
  // reason, otherwise. SolveIk takes the same choice.
  EXPECT_TRUE(ChooseIkSolver(puma, {}).closed_form);
  EXPECT_EQ(ChooseIkSolver(puma, {true, false}).not_closed_form, "numeric solver asked for");
  EXPECT_EQ(ChooseIkSolver(puma, {false, true}).not_closed_form, "position-only target");
  const RobotModel planar = LoadRobotModel("config/robots/planar3.yaml");
  EXPECT_FALSE(ChooseIkSolver(planar, {}).closed_form);
  EXPECT_EQ(ChooseIkSolver(planar, {}).not_closed_form, "it uses modified DH");
  const JointVector q = (JointVector(6) << 0.3, -0.6, 1.1, 0.2, 0.7, -0.4).finished();
  const Eigen::Isometry3d target = ToolPose(puma, q);
  const IkResult closed = SolveIk(puma, target, q, {});
  ASSERT_TRUE(closed.ok()) << closed.reason;
  EXPECT_TRUE(closed.solutions.front().config.has_value());  // labelled: the closed form's
  const IkResult numeric = SolveIk(puma, target, q, {true, false});
  ASSERT_TRUE(numeric.ok()) << numeric.reason;
  EXPECT_FALSE(numeric.solutions.front().config.has_value());
  EXPECT_LT(numeric.solutions.front().error.position_m, 1e-6);
}

TEST_F(PumaIk, RandomPosesRoundTripOnAllEightBranches) {
  // Thousands of poses reached by random joints (fixed seed): every returned solution reproduces
  // the pose to 1e-9, the 8 configurations are distinct, and the original joints are among them.
  std::mt19937 random(2009);
  std::map<std::string, int> label_counts;
  double worst_position = 0, worst_rotation = 0;
  int eight = 0;
  const int trials = 3000;
  for (int trial = 0; trial < trials; ++trial) {
    const JointVector q = RandomJoints(puma, random);
    const Eigen::Isometry3d target = ToolPose(puma, q);
    const IkResult result = SolvePumaIk(puma, target, q);
    ASSERT_FALSE(result.solutions.empty()) << "trial " << trial;
    std::set<std::string> labels;
    bool found_original = false;
    for (const IkSolution& s : result.solutions) {
      const PoseError e = ComparePoses(ToolPose(puma, s.q), target);
      worst_position = std::max(worst_position, e.position_m);
      worst_rotation = std::max(worst_rotation, e.rotation_rad);
      ASSERT_TRUE(s.config.has_value());
      EXPECT_EQ(s.config->Name(), MeasuredConfiguration(puma, s.q).Name()) << "trial " << trial;
      labels.insert(s.config->Name());
      label_counts[s.config->Name()]++;
      found_original = found_original || SameUpToTurns(puma, s.q, q, 1e-7);
    }
    if (result.solutions.size() == 8) {
      ++eight;
      EXPECT_EQ(labels.size(), 8U) << "trial " << trial;
    }
    EXPECT_TRUE(found_original) << "trial " << trial;
  }
  EXPECT_LT(worst_position, 1e-9);
  EXPECT_LT(worst_rotation, 1e-9);
  EXPECT_EQ(eight, trials);  // random poses are not singular, so all 8 branches exist
  EXPECT_EQ(label_counts.size(), 8U);
  for (const auto& [label, count] : label_counts) EXPECT_EQ(count, trials) << label;
  std::printf(
      "PUMA 260 closed-form IK, %d random poses: worst |FK(IK(T)) - T| = %.3g m, %.3g rad\n",
      trials, worst_position, worst_rotation);
}

TEST_F(PumaIk, ConfigurationChoiceAndNearest) {
  const JointVector q = (JointVector(6) << 20, -40, 60, 10, 30, -20).finished() * kDeg;
  const IkResult result = SolvePumaIk(puma, ToolPose(puma, q), q);
  ASSERT_TRUE(result.ok());
  const IkSolution* nearest = NearestSolution(result, q);
  ASSERT_NE(nearest, nullptr);
  EXPECT_TRUE(SameUpToTurns(puma, nearest->q, q, 1e-9));
  // Each configuration names a different arm posture: flipping the wrist changes joints 4-6 only.
  const IkConfiguration mine = *nearest->config;
  IkConfiguration flipped = mine;
  flipped.wrist_flip = !flipped.wrist_flip;
  for (const IkSolution& s : result.solutions) {
    if (s.config == flipped) {
      EXPECT_NEAR(std::remainder(s.q[0] - nearest->q[0], 2 * M_PI), 0, 1e-9);
      EXPECT_NEAR(s.q[4], -nearest->q[4], 1e-9);
    }
  }
  EXPECT_EQ(IkConfiguration::Parse(mine.Name()), mine);
  EXPECT_FALSE(IkConfiguration::Parse("left-sideways-flip"));
}

TEST_F(PumaIk, ElbowLabelFollowsGeometry) {
  // Arm ready pose: upper arm straight up (joint 2 at -90), forearm forward (joint 3 at +90) puts
  // the elbow above the shoulder-wrist line.
  const JointVector q = (JointVector(6) << 0, -90, 90, 0, 45, 0).finished() * kDeg;
  const IkResult result = SolvePumaIk(puma, ToolPose(puma, q), q);
  const IkSolution* nearest = NearestSolution(result, q);
  ASSERT_NE(nearest, nullptr);
  EXPECT_TRUE(nearest->config->elbow_up) << nearest->config->Name();
  EXPECT_FALSE(nearest->config->wrist_flip);
}

TEST_F(PumaIk, UnreachableTargetsSayWhy) {
  Eigen::Isometry3d far = Eigen::Isometry3d::Identity();
  far.translation() << 2.0, 0, 0.5;  // the arm reaches about 0.5 m
  const IkResult result = SolvePumaIk(puma, far, JointVector::Zero(6));
  EXPECT_EQ(result.failure, IkFailure::kUnreachable);
  EXPECT_TRUE(result.solutions.empty());
  EXPECT_NE(result.reason.find("the arm reaches"), std::string::npos) << result.reason;

  // Wrist centre closer to the waist axis than the 5.6 inch lateral offset.
  Eigen::Isometry3d close = Eigen::Isometry3d::Identity();
  close.translation() << 0.02, 0.0, 0.5 + 2.2 * 0.0254;
  const IkResult inside = SolvePumaIk(puma, close, JointVector::Zero(6));
  EXPECT_EQ(inside.failure, IkFailure::kUnreachable);
  EXPECT_NE(inside.reason.find("lateral offset"), std::string::npos) << inside.reason;
}

TEST_F(PumaIk, WristSingularTargetIsSolvedAndNamed) {
  const JointVector q = (JointVector(6) << 10, 20, 30, 25, 0, 15).finished() * kDeg;
  const Eigen::Isometry3d target = ToolPose(puma, q);
  const IkResult result = SolvePumaIk(puma, target, q);
  ASSERT_TRUE(result.ok()) << result.reason;
  const IkSolution* nearest = NearestSolution(result, q);
  ASSERT_NE(nearest, nullptr);
  EXPECT_LT(nearest->error.position_m, 1e-9);
  EXPECT_LT(nearest->error.rotation_rad, 1e-9);
  EXPECT_NE(std::find(nearest->singularities.begin(), nearest->singularities.end(), "wrist"),
            nearest->singularities.end());
  // Joint 4 keeps the reference value; joints 4 and 6 share the roll.
  EXPECT_NEAR(nearest->q[3], q[3], 1e-9);
}

TEST_F(PumaIk, ElbowAndShoulderSingularitiesAreNamed) {
  // Elbow: forearm in line with the upper arm (theta3 + beta = 0 with beta = -90 for this table).
  const JointVector stretched = (JointVector(6) << 0, 0, 90, 0, 30, 0).finished() * kDeg;
  const auto elbow = Singularities(puma, stretched);
  EXPECT_NE(std::find(elbow.begin(), elbow.end(), "elbow"), elbow.end());
  EXPECT_EQ(std::count(elbow.begin(), elbow.end(), "shoulder"), 0);
  // Shoulder: upper arm 45 degrees up, forearm at 0: the wrist centre is straight above the
  // shoulder, on the cylinder where the left and right solutions meet.
  const JointVector aligned = (JointVector(6) << 0, -45, 0, 0, 30, 0).finished() * kDeg;
  EXPECT_EQ(Singularities(puma, aligned), std::vector<std::string>{"shoulder"});
  const JointVector regular = (JointVector(6) << 0, 20, 40, 0, 30, 0).finished() * kDeg;
  EXPECT_TRUE(Singularities(puma, regular).empty());
}

TEST_F(PumaIk, LimitsAreRespected) {
  std::mt19937 random(99);
  for (int trial = 0; trial < 300; ++trial) {
    const JointVector q = RandomJoints(puma, random);
    const IkResult result = SolvePumaIk(puma, ToolPose(puma, q), JointVector::Zero(6));
    for (const IkSolution& s : result.solutions) {
      bool inside = true;
      for (int i = 0; i < 6; ++i) {
        const Joint& joint = puma.joints[static_cast<size_t>(i)];
        inside =
            inside && s.q[i] >= joint.position_min - 1e-12 && s.q[i] <= joint.position_max + 1e-12;
      }
      EXPECT_EQ(inside, s.within_limits);
    }
  }
  // Narrow the waist so that only the original posture's half fits, then shut it completely.
  RobotModel narrow = puma;
  narrow.joints[0].position_min = -5 * kDeg;
  narrow.joints[0].position_max = 5 * kDeg;
  const JointVector q = (JointVector(6) << 0, 20, 40, 0, 30, 0).finished() * kDeg;
  const IkResult some = SolvePumaIk(narrow, ToolPose(narrow, q), q);
  ASSERT_TRUE(some.ok());
  for (const IkSolution& s : some.solutions) {
    if (s.within_limits) {
      EXPECT_LE(std::abs(s.q[0]), 5 * kDeg + 1e-12);
    }
  }
  narrow.joints[0].position_min = 100 * kDeg;
  narrow.joints[0].position_max = 110 * kDeg;
  const IkResult none = SolvePumaIk(narrow, ToolPose(puma, q), q);
  EXPECT_EQ(none.failure, IkFailure::kOutsideJointLimits);
  EXPECT_FALSE(none.solutions.empty());
  for (const IkSolution& s : none.solutions) EXPECT_FALSE(s.within_limits);
}

TEST_F(PumaIk, NumericSolverAgreesWithClosedForm) {
  // Away from singularities (within about a degree of one the damped solver may stall short of
  // 1e-9 and then says "singular", as NumericIk.StaysBoundedNearASingularity shows).
  std::mt19937 random(5);
  for (int trial = 0; trial < 30; ++trial) {
    const JointVector q = RandomJoints(puma, random);
    if (!Singularities(puma, q, 0.02).empty()) continue;
    const Eigen::Isometry3d target = ToolPose(puma, q);
    NumericIkOptions options;
    options.stop_at_first = true;
    const IkResult numeric =
        SolveNumericIk(puma, target, q + JointVector::Constant(6, 0.2), options);
    ASSERT_TRUE(numeric.ok()) << numeric.reason;
    const IkResult closed = SolvePumaIk(puma, target, numeric.solutions[0].q);
    bool matched = false;
    for (const IkSolution& s : closed.solutions) {
      matched = matched || SameUpToTurns(puma, s.q, numeric.solutions[0].q, 1e-6);
    }
    EXPECT_TRUE(matched) << "trial " << trial;
  }
}

TEST(NumericIk, ReachesRandomTargetsOnTheNonPumaArms) {
  for (const char* file : {"config/robots/planar3.yaml", "config/robots/stanford.yaml"}) {
    SCOPED_TRACE(file);
    const RobotModel model = LoadRobotModel(file);
    std::mt19937 random(31);
    int solved = 0;
    for (int trial = 0; trial < 40; ++trial) {
      const JointVector q = RandomJoints(model, random, 0.05);
      const Eigen::Isometry3d target = ToolPose(model, q);
      JointVector home(model.num_joints());
      for (int i = 0; i < home.size(); ++i) home[i] = model.joints[static_cast<size_t>(i)].home;
      const IkResult result = SolveNumericIk(model, target, home);
      if (!result.ok()) continue;
      ++solved;
      for (const IkSolution& s : result.solutions) {
        EXPECT_LT(ComparePoses(ToolPose(model, s.q), target).position_m, 1e-9);
        EXPECT_LT(ComparePoses(ToolPose(model, s.q), target).rotation_rad, 1e-9);
        for (int i = 0; i < s.q.size(); ++i) {
          const Joint& joint = model.joints[static_cast<size_t>(i)];
          EXPECT_GE(s.q[i], joint.position_min);
          EXPECT_LE(s.q[i], joint.position_max);
        }
      }
    }
    EXPECT_GE(solved, 38) << "of 40";
  }
}

TEST(NumericIk, ReasonsForFailure) {
  const RobotModel arm = LoadRobotModel("config/robots/planar3.yaml");
  Eigen::Isometry3d far = Eigen::Isometry3d::Identity();
  far.translation() << 3, 0, 0.5;
  EXPECT_EQ(SolveNumericIk(arm, far, JointVector::Zero(3)).failure, IkFailure::kUnreachable);

  // Reachable only with the elbow bent further than its limit allows.
  RobotModel stiff = arm;
  stiff.joints[1].position_min = -10 * kDeg;
  stiff.joints[1].position_max = 10 * kDeg;
  const Eigen::Isometry3d bent = ToolPose(arm, (JointVector(3) << 0, 120, 0).finished() * kDeg);
  const IkResult limited = SolveNumericIk(stiff, bent, JointVector::Zero(3));
  EXPECT_EQ(limited.failure, IkFailure::kOutsideJointLimits) << limited.reason;

  // A pose out of the arm's plane: within reach, but no configuration gives it.
  Eigen::Isometry3d off_plane = ToolPose(arm, (JointVector(3) << 0, 90, -90).finished() * kDeg);
  off_plane.translation().y() += 0.1;
  const IkResult stuck = SolveNumericIk(arm, off_plane, JointVector::Zero(3));
  EXPECT_FALSE(stuck.ok());
  EXPECT_TRUE(stuck.failure == IkFailure::kNoConvergence || stuck.failure == IkFailure::kSingular)
      << IkFailureName(stuck.failure);
  EXPECT_TRUE(stuck.solutions.empty());
}

TEST(NumericIk, StaysBoundedNearASingularity) {
  // Target just beyond the fully stretched planar arm: the damped steps must not blow up.
  const RobotModel arm = LoadRobotModel("config/robots/planar3.yaml");
  Eigen::Isometry3d target = ToolPose(arm, JointVector::Zero(3));
  target.translation().x() += 1e-4;
  NumericIkOptions options;
  options.random_seeds = 2;
  const IkResult result = SolveNumericIk(arm, target, JointVector::Constant(3, 0.01), options);
  EXPECT_FALSE(result.ok());
  EXPECT_TRUE(result.failure == IkFailure::kSingular ||
              result.failure == IkFailure::kNoConvergence ||
              result.failure == IkFailure::kUnreachable)
      << result.reason;
}

}  // namespace
}  // namespace sirupp::core
