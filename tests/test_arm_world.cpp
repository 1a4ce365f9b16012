// The virtual robot in ODE (sim/arm_world.hpp): geometry against forward kinematics, unwrapped
// angles, limits, and physics checks against numbers computed here without ODE (closed forms and a
// small rigid-body model of our own: gravity torques and mass matrix from finite differences of
// forward kinematics, an RK4 pendulum).

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <chrono>
#include <cmath>
#include <cstring>
#include <random>
#include <sirupp/arm_state_t.hpp>

#include "core/environment.hpp"
#include "core/errors.hpp"
#include "core/kinematics.hpp"
#include "core/model_loader.hpp"
#include "sim/arm_world.hpp"
#include "sim/model_change.hpp"

namespace sirupp::sim {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180;

core::RobotModel Puma() { return core::LoadRobotModel("config/robots/puma260.yaml"); }

core::ArmCommand Effort(std::vector<double> effort) {
  core::ArmCommand command;
  command.mode = core::CommandMode::kEffort;
  command.effort = std::move(effort);
  return command;
}

core::ArmCommand Limp(int n) {
  core::ArmCommand command = Effort(std::vector<double>(static_cast<size_t>(n), 0.0));
  command.mode = core::CommandMode::kLimp;
  return command;
}

void WidenLimits(core::RobotModel& model) {
  for (core::Joint& joint : model.joints) {
    joint.position_min = -1000 * kDeg;
    joint.position_max = 1000 * kDeg;
  }
}

// One revolute joint from the two-link test arm: link 1 is a 0.3 m bar along x1 (1 kg, centre of
// mass 0.15 m from the axis). The joint axis is vertical, or horizontal when `pendulum` (the base
// is rolled 90 degrees, so gravity swings the bar).
core::RobotModel OneJoint(bool pendulum) {
  core::RobotModel model = core::LoadRobotModel("tests/data/good_two_link.yaml");
  model.joints.resize(1);
  model.links.resize(2);
  model.joints[0].armature = 0;
  model.joints[0].friction = core::Friction{};
  model.joints[0].position_min = -1000 * kDeg;
  model.joints[0].position_max = 1000 * kDeg;
  if (pendulum) model.base.orientation = core::QuaternionFromRpy(kPi / 2, 0, 0);
  return model;
}

// Moment of inertia of link 1 of OneJoint() about its joint axis (z of frame 0 = z of frame 1).
double AxisInertia(const core::RobotModel& model) {
  const core::Link& link = model.links[1];
  return link.inertia_kg_m2(2, 2) + link.mass_kg * link.com_m.head<2>().squaredNorm();
}

// World positions of every link's centre of mass at q.
std::vector<Eigen::Vector3d> Centres(const core::RobotModel& model, const core::JointVector& q) {
  const core::ForwardResult fk = core::ForwardKinematics(model, q);
  std::vector<Eigen::Vector3d> centres;
  for (int i = 1; i <= model.num_joints(); ++i) {
    centres.push_back(fk.frames[static_cast<size_t>(i)] *
                      model.links[static_cast<size_t>(i)].com_m);
  }
  return centres;
}

// Our own rigid-body model (revolute, standard-DH arms): linear Jacobians of the centres by central
// differences of FK, angular Jacobians from the joint axes.
struct RigidBody {
  Eigen::VectorXd gravity_torque;  // effort the joints must supply to hold the arm at q
  Eigen::MatrixXd mass_matrix;
};

RigidBody RigidBodyAt(const core::RobotModel& model, const core::JointVector& q) {
  const int n = model.num_joints();
  const double h = 1e-6;
  std::vector<Eigen::MatrixXd> jv(static_cast<size_t>(n), Eigen::MatrixXd::Zero(3, n));
  for (int j = 0; j < n; ++j) {
    core::JointVector plus = q, minus = q;
    plus[j] += h;
    minus[j] -= h;
    const auto cp = Centres(model, plus), cm = Centres(model, minus);
    for (int l = 0; l < n; ++l) {
      jv[static_cast<size_t>(l)].col(j) =
          (cp[static_cast<size_t>(l)] - cm[static_cast<size_t>(l)]) / (2 * h);
    }
  }
  const core::ForwardResult fk = core::ForwardKinematics(model, q);
  RigidBody rb;
  rb.gravity_torque = Eigen::VectorXd::Zero(n);
  rb.mass_matrix = Eigen::MatrixXd::Zero(n, n);
  for (int l = 1; l <= n; ++l) {
    const core::Link& link = model.links[static_cast<size_t>(l)];
    const Eigen::MatrixXd& j_v = jv[static_cast<size_t>(l - 1)];
    Eigen::MatrixXd j_w = Eigen::MatrixXd::Zero(3, n);
    for (int j = 1; j <= l; ++j)
      j_w.col(j - 1) = fk.frames[static_cast<size_t>(j - 1)].linear().col(2);
    const Eigen::Matrix3d r = fk.frames[static_cast<size_t>(l)].linear();
    const Eigen::Matrix3d inertia_world = r * link.inertia_kg_m2 * r.transpose();
    rb.mass_matrix += link.mass_kg * j_v.transpose() * j_v + j_w.transpose() * inertia_world * j_w;
    rb.gravity_torque -= link.mass_kg * j_v.transpose() * model.gravity_m_s2;
  }
  return rb;
}

// Total mechanical energy from the bodies' states and the model's masses (armature excluded).
double Energy(const ArmWorld& world) {
  const core::RobotModel& model = world.model();
  double energy = 0;
  for (int l = 1; l <= model.num_joints(); ++l) {
    const core::Link& link = model.links[static_cast<size_t>(l)];
    const Eigen::Isometry3d pose = world.LinkBodyPose(l);
    const Eigen::Vector3d v = world.LinkLinearVelocity(l);
    const Eigen::Vector3d w = world.LinkAngularVelocity(l);
    const Eigen::Matrix3d inertia = pose.linear() * link.inertia_kg_m2 * pose.linear().transpose();
    energy += 0.5 * link.mass_kg * v.squaredNorm() + 0.5 * w.dot(inertia * w) -
              link.mass_kg * model.gravity_m_s2.dot(pose.translation());
  }
  return energy;
}

void ExpectBodiesOnForwardKinematics(const ArmWorld& world, double tolerance_m,
                                     double tolerance_rad) {
  const core::RobotModel& model = world.model();
  const core::ArmState state = world.State();
  const core::ForwardResult fk =
      core::ForwardKinematics(model, core::ToJointVector(state.position));
  for (int i = 1; i <= model.num_joints(); ++i) {
    Eigen::Isometry3d expected = fk.frames[static_cast<size_t>(i)];
    expected.translation() = expected * model.links[static_cast<size_t>(i)].com_m;
    const core::PoseError error = core::ComparePoses(world.LinkBodyPose(i), expected);
    EXPECT_LT(error.position_m, tolerance_m) << model.name << " link " << i;
    EXPECT_LT(error.rotation_rad, tolerance_rad) << model.name << " link " << i;
  }
}

TEST(ArmWorld, BodiesSitWhereForwardKinematicsPutsEachLinksCentreOfMass) {
  std::mt19937 random(7);
  for (const char* file : {"config/robots/puma260.yaml", "config/robots/planar3.yaml",
                           "config/robots/stanford.yaml"}) {
    const core::RobotModel model = core::LoadRobotModel(file);
    ArmWorld world(model, core::Environment{});
    ExpectBodiesOnForwardKinematics(world, 1e-12, 1e-12);  // home pose
    for (int trial = 0; trial < 20; ++trial) {
      std::vector<double> q;
      for (const core::Joint& joint : model.joints) {
        q.push_back(
            std::uniform_real_distribution<double>(joint.position_min, joint.position_max)(random));
      }
      world.SetJointState(q);
      ExpectBodiesOnForwardKinematics(world, 1e-12, 1e-12);
      // After 0.2 s of free fall the reported joints still reproduce every body, within ODE's joint
      // drift (links creep apart by microns under fast motion, pulled back by ERP).
      for (int k = 0; k < 400; ++k) world.Step(Limp(model.num_joints()));
      ExpectBodiesOnForwardKinematics(world, 1e-4, 1e-4);
    }
  }
}

TEST(ArmWorld, RevoluteAnglesAreUnwrappedPastHalfATurn) {
  core::RobotModel model = OneJoint(false);  // vertical axis: gravity exerts no torque
  model.joints[0].position_min = -3600 * kDeg;
  model.joints[0].position_max = 3600 * kDeg;
  ArmWorld world(model, core::Environment{});
  const double speed = 2 * kPi;  // one turn per second
  world.SetJointState({0.1}, {speed});
  // The reported position must be the integral of the reported speed: no jump of 2 pi anywhere.
  double integral = 0.1;
  double previous_speed = speed;
  const int steps = static_cast<int>(std::lround(3.0 / world.step_s()));
  double max_mismatch = 0;
  for (int k = 1; k <= steps; ++k) {
    world.Step(Effort({0.0}));
    const core::ArmState state = world.State();
    integral += 0.5 * (previous_speed + state.velocity[0]) * world.step_s();
    previous_speed = state.velocity[0];
    max_mismatch = std::max(max_mismatch, std::abs(state.position[0] - integral));
  }
  // ODE's joint drift (the bar creeps outwards by microns, pulled back by ERP) costs a little speed
  // and makes angle and speed disagree slightly; a lost or doubled turn would be 6.28 rad.
  EXPECT_LT(max_mismatch, 1e-4);
  EXPECT_NEAR(world.State().position[0], 0.1 + 3 * 2 * kPi, 3e-3);  // three turns
  ExpectBodiesOnForwardKinematics(world, 1e-5, 1e-5);
}

TEST(ArmWorld, LimitsBeyondHalfATurnAreEnforcedInBothDirections) {
  core::RobotModel model = OneJoint(false);
  model.joints[0].position_min = -310 * kDeg;
  model.joints[0].position_max = 310 * kDeg;
  ArmWorld world(model, core::Environment{});
  for (const double effort : {2.0, -2.0}) {
    const double limit = effort > 0 ? 310 * kDeg : -310 * kDeg;
    double extreme = 0;
    for (int k = 0; k < 8000; ++k) {
      world.Step(Effort({effort}));
      const double q = world.State().position[0];
      extreme = effort > 0 ? std::max(extreme, q) : std::min(extreme, q);
    }
    const core::ArmState state = world.State();
    EXPECT_NEAR(state.position[0], limit, 0.5 * kDeg) << "effort " << effort;
    EXPECT_LT(std::abs(extreme - limit), 1 * kDeg) << "overshoot past the stop";
    EXPECT_TRUE(state.flags[0] & (effort > 0 ? sirupp::arm_state_t::FLAG_AT_UPPER_LIMIT
                                             : sirupp::arm_state_t::FLAG_AT_LOWER_LIMIT));
  }
}

TEST(ArmWorld, EffortIsClampedToTheJointsLimit) {
  core::RobotModel model = OneJoint(false);
  ArmWorld world(model, core::Environment{});
  world.Step(Effort({1000.0}));
  EXPECT_EQ(world.State().effort[0], model.joints[0].effort_max);
  world.Step(Effort({-1000.0}));
  EXPECT_EQ(world.State().effort[0], -model.joints[0].effort_max);
  // The clamped effort is what accelerates the arm: alpha = effort_max / inertia.
  world.SetJointState({0.0});
  world.Step(Effort({1000.0}));
  EXPECT_NEAR(world.State().velocity[0] / world.step_s(),
              model.joints[0].effort_max / AxisInertia(model),
              1e-6 * model.joints[0].effort_max / AxisInertia(model));
}

TEST(ArmWorld, BadCommandsAndTeleportsAreRefusedAndChangeNothing) {
  ArmWorld world(Puma(), core::Environment{});
  const core::ArmState before = world.State();
  EXPECT_THROW(world.Step(Effort({1, 2, 3})), std::invalid_argument);
  EXPECT_THROW(world.Step(Effort({0, 0, NAN, 0, 0, 0})), std::invalid_argument);
  EXPECT_THROW(world.Step(Effort({0, 0, 0, INFINITY, 0, 0})), std::invalid_argument);
  try {
    world.SetJointState({0, 0, 0, 7, 0, 0});
    FAIL() << "teleport outside the limits accepted";
  } catch (const std::invalid_argument& error) {
    EXPECT_NE(std::string(error.what()).find("joints[3] (wrist_roll)"), std::string::npos)
        << error.what();
    EXPECT_NE(std::string(error.what()).find("outside the limits"), std::string::npos);
  }
  EXPECT_EQ(world.State().position, before.position);
  EXPECT_EQ(world.tick(), 0);
}

TEST(ArmWorld, GravitySagGoesWhereOurOwnRigidBodyModelSays) {
  core::RobotModel model = Puma();
  WorldOptions options;
  options.friction = false;
  options.armature = false;
  ArmWorld world(model, core::Environment{}, options);
  const std::vector<double> q0 = {0.3, 0.4, -0.5, 0.2, 0.6, 0.1};
  world.SetJointState(q0);
  const RigidBody rb = RigidBodyAt(model, core::ToJointVector(q0));
  // Released from rest, the joints accelerate at M^-1 * (-G): compare ODE's first step with ours.
  world.Step(Limp(6));
  const Eigen::VectorXd accel = core::ToJointVector(world.State().velocity) / world.step_s();
  const Eigen::VectorXd expected = rb.mass_matrix.ldlt().solve(-rb.gravity_torque);
  for (int j = 0; j < 6; ++j) {
    EXPECT_NEAR(accel[j], expected[j], 0.01 * expected.cwiseAbs().maxCoeff()) << "joint " << j;
  }
  // A moment later the arm has sagged: lower, with joint 2 moving down the gravity torque.
  for (int k = 0; k < 100; ++k) world.Step(Limp(6));
  double potential_drop = 0;
  const auto before = Centres(model, core::ToJointVector(q0));
  const auto after = Centres(model, core::ToJointVector(world.State().position));
  for (int l = 0; l < 6; ++l) {
    potential_drop +=
        model.links[static_cast<size_t>(l + 1)].mass_kg *
        model.gravity_m_s2.dot(after[static_cast<size_t>(l)] - before[static_cast<size_t>(l)]);
  }
  EXPECT_GT(potential_drop, 0) << "the arm must lose height";
  EXPECT_LT((world.State().position[1] - q0[1]) * rb.gravity_torque[1], 0);
}

// Energy including the rotors: each joint's armature spins with the child link's angular velocity
// about the joint axis (z of DH frame i-1, standard DH).
double EnergyWithRotors(const ArmWorld& world) {
  const core::RobotModel& model = world.model();
  const core::ForwardResult fk =
      core::ForwardKinematics(model, core::ToJointVector(world.State().position));
  double energy = Energy(world);
  for (int l = 1; l <= model.num_joints(); ++l) {
    const double spin =
        world.LinkAngularVelocity(l).dot(fk.frames[static_cast<size_t>(l - 1)].linear().col(2));
    energy += 0.5 * model.joints[static_cast<size_t>(l - 1)].armature * spin * spin;
  }
  return energy;
}

// Largest energy error over `seconds` of a frictionless swing of the PUMA 260 about its hanging
// pose, as a fraction of the swing's energy (start energy minus energy at rest hanging).
double EnergyErrorOfSwing(double step_s, double seconds) {
  core::RobotModel model = Puma();
  WidenLimits(model);
  WorldOptions options;
  options.friction = false;
  options.step_s = step_s;
  ArmWorld world(model, core::Environment{}, options);
  const std::vector<double> hanging = {0, 90 * kDeg, 90 * kDeg, 0, 0, 0};
  world.SetJointState(hanging);
  const double rest = EnergyWithRotors(world);
  world.SetJointState({0, 115 * kDeg, 70 * kDeg, 0, 30 * kDeg, 0}, {0.5, 0, 0, 1.0, 0, 0});
  const double start = EnergyWithRotors(world);
  double worst = 0;
  const int steps = static_cast<int>(std::lround(seconds / step_s));
  for (int k = 1; k <= steps; ++k) {
    world.Step(Limp(6));
    if (k % 50 == 0) worst = std::max(worst, std::abs(EnergyWithRotors(world) - start));
  }
  std::printf(
      "energy: step %.3f ms, swing energy %.4f J, worst error over %.0f s %.4f J (%.2f%%)\n",
      step_s * 1e3, start - rest, seconds, worst, 100 * worst / (start - rest));
  return worst / (start - rest);
}

TEST(ArmWorld, WithoutFrictionEnergyStaysWithinTheStatedBoundAndShrinksWithTheStep) {
  // docs/physics.md: dWorldStep is first order, so the error is a slow loss proportional to the
  // step, largest where the light wrist whips about. Stated bound at the default step: 60 % of the
  // swing energy over 10 s (measured: about 47 %); a 4x smaller step must cut it at least 2.5x
  // (first-order convergence: a numerical loss, not a modelling error).
  const double coarse = EnergyErrorOfSwing(0.000512, 10.0);
  const double fine = EnergyErrorOfSwing(0.000128, 10.0);
  EXPECT_LT(coarse, 0.60);
  EXPECT_LT(fine, coarse / 2.5);
}

TEST(ArmWorld, GravityTorquesHoldTheArmStill) {
  core::RobotModel model = Puma();
  WorldOptions options;
  options.friction = false;
  ArmWorld world(model, core::Environment{}, options);
  const std::vector<double> q0 = {0.3, 0.4, -0.5, 0.2, 0.6, 0.1};
  world.SetJointState(q0);
  const RigidBody rb = RigidBodyAt(model, core::ToJointVector(q0));
  std::vector<double> hold(rb.gravity_torque.data(), rb.gravity_torque.data() + 6);
  const int steps = static_cast<int>(std::lround(1.0 / world.step_s()));
  double worst = 0;
  for (int k = 0; k < steps; ++k) {
    world.Step(Effort(hold));
    for (int j = 0; j < 6; ++j) {
      worst = std::max(worst, std::abs(world.State().position[static_cast<size_t>(j)] -
                                       q0[static_cast<size_t>(j)]));
    }
  }
  std::printf("gravity hold: worst joint drift over 1 s %.3e rad\n", worst);
  EXPECT_LT(worst, 1e-4);
  // And the same arm limp falls: the torques were doing the holding.
  for (int k = 0; k < 200; ++k) world.Step(Limp(6));
  EXPECT_GT(std::abs(world.State().position[1] - q0[1]), 1e-3);
}

// A joint with friction: static 0.9, Coulomb 0.7 / 0.5, viscous 0.3 (N*m, N*m*s/rad).
core::RobotModel FrictionJoint() {
  core::RobotModel model = OneJoint(false);
  model.joints[0].friction.static_effort = 0.9;
  model.joints[0].friction.coulomb_positive = 0.7;
  model.joints[0].friction.coulomb_negative = 0.5;
  model.joints[0].friction.viscous = 0.3;
  model.joints[0].friction.stribeck_velocity = 0.05;
  return model;
}

TEST(ArmWorld, BelowBreakAwayAJointDoesNotMoveAtAll) {
  ArmWorld world(FrictionJoint(), core::Environment{});
  for (const double effort : {0.89, -0.89, 0.5}) {
    for (int k = 0; k < 2000; ++k) world.Step(Effort({effort}));
    EXPECT_LT(std::abs(world.State().position[0]), 1e-9) << "effort " << effort;
    EXPECT_TRUE(world.State().flags[0] & sirupp::arm_state_t::FLAG_STICKING);
  }
  for (int k = 0; k < 200; ++k) world.Step(Effort({0.91}));
  EXPECT_GT(world.State().position[0], 1e-6);
  EXPECT_FALSE(world.State().flags[0] & sirupp::arm_state_t::FLAG_STICKING);
}

TEST(ArmWorld, UnderARampedTorqueBreakAwayComesWhenTheTorqueReachesStaticFriction) {
  const core::RobotModel model = FrictionJoint();
  for (const double rate : {2.0, 5.0, -3.0}) {  // N*m/s
    ArmWorld world(model, core::Environment{});
    double breakaway_s = -1;
    for (int k = 0; k < 4000 && breakaway_s < 0; ++k) {
      const double t = world.time_s();
      world.Step(Effort({rate * t}));
      if (std::abs(world.State().position[0]) > 1e-9) breakaway_s = t;
    }
    const double expected_s = 0.9 / std::abs(rate);
    std::printf("ramp %.1f N*m/s: break-away after %.4f s, static/rate = %.4f s\n", rate,
                breakaway_s, expected_s);
    EXPECT_NEAR(breakaway_s, expected_s, 2 * world.step_s()) << "rate " << rate;
  }
}

TEST(ArmWorld, SlidingFeelsCoulombByDirectionPlusViscous) {
  const core::RobotModel model = FrictionJoint();
  for (const double effort : {1.5, -1.5}) {
    ArmWorld world(model, core::Environment{});
    for (int k = 0; k < 4000; ++k) world.Step(Effort({effort}));  // ~2 s, time constant I/B ~ 0.1 s
    const double coulomb = effort > 0 ? 0.7 : 0.5;
    const double terminal = std::copysign((std::abs(effort) - coulomb) / 0.3, effort);
    EXPECT_NEAR(world.State().velocity[0], terminal, 1e-3 * std::abs(terminal)) << effort;
  }
}

TEST(ArmWorld, SlidingFrictionAsATorqueMovesTheArmExactlyAsTheFrictionRowDoes) {
  // The fast path (kinetic friction as a plain torque while a joint slides, the step redone with
  // the row when a joint would stop) must give the motion of the all-rows formulation.
  auto run = [](bool always_rows) {
    WorldOptions options;
    options.always_friction_rows = always_rows;
    ArmWorld world(Puma(), core::Environment{}, options);
    std::vector<double> trace;
    for (int k = 0; k < 4000; ++k) {
      const double t = world.time_s();
      // Efforts that reverse the joints often, through stick and slip.
      world.Step(Effort({1.5 * std::sin(9 * t), 3 * std::sin(7 * t), 2 * std::sin(11 * t),
                         0.3 * std::sin(13 * t), 0.3 * std::sin(5 * t), 0.2 * std::sin(17 * t)}));
      const core::ArmState state = world.State();
      trace.insert(trace.end(), state.position.begin(), state.position.end());
    }
    return trace;
  };
  const std::vector<double> rows = run(true);
  const std::vector<double> fast = run(false);
  double worst = 0;
  for (size_t i = 0; i < rows.size(); ++i) worst = std::max(worst, std::abs(rows[i] - fast[i]));
  std::printf("friction as torque vs friction row: worst position difference %.3e rad\n", worst);
  EXPECT_LT(worst, 1e-7);
}

TEST(ArmWorld, ASingleJointSwingHasThePendulumsPeriod) {
  const core::RobotModel model = OneJoint(true);
  WorldOptions options;
  options.friction = false;
  ArmWorld world(model, core::Environment{}, options);
  // Where does the bar hang? With the base rolled +90 degrees, gravity pulls the centre of mass
  // towards -z; find the hanging angle from FK, then swing 20 degrees from it.
  const core::Link& link = model.links[1];
  const double mgl = link.mass_kg * 9.81 * link.com_m.norm();
  const double inertia = AxisInertia(model);
  double hang = 0;
  double lowest = 1e9;
  for (double q = -kPi; q < kPi; q += 1e-4) {
    const double z = Centres(model, core::ToJointVector({q}))[0].z();
    if (z < lowest) lowest = z, hang = q;
  }
  const double amplitude = 20 * kDeg;
  world.SetJointState({hang + amplitude});
  // Our reference: RK4 on phi'' = -(m g l / I) sin(phi), period from successive upward zero
  // crossings.
  auto reference_period = [&] {
    double phi = amplitude, omega = 0, t = 0;
    const double dt = 1e-5;
    std::vector<double> crossings;
    while (crossings.size() < 3) {
      auto f = [&](double p) { return -mgl / inertia * std::sin(p); };
      const double k1p = omega, k1w = f(phi);
      const double k2p = omega + 0.5 * dt * k1w, k2w = f(phi + 0.5 * dt * k1p);
      const double k3p = omega + 0.5 * dt * k2w, k3w = f(phi + 0.5 * dt * k2p);
      const double k4p = omega + dt * k3w, k4w = f(phi + dt * k3p);
      const double next_phi = phi + dt / 6 * (k1p + 2 * k2p + 2 * k3p + k4p);
      omega += dt / 6 * (k1w + 2 * k2w + 2 * k3w + k4w);
      if (phi < 0 && next_phi >= 0) crossings.push_back(t + dt * (-phi) / (next_phi - phi));
      phi = next_phi;
      t += dt;
    }
    return (crossings[2] - crossings[0]) / 2;
  }();
  std::vector<double> crossings;
  double previous = amplitude;
  while (crossings.size() < 3 && world.time_s() < 20) {
    const double t0 = world.time_s();
    world.Step(Effort({0.0}));
    const double phi = world.State().position[0] - hang;
    if (previous < 0 && phi >= 0) {
      crossings.push_back(t0 + world.step_s() * (-previous) / (phi - previous));
    }
    previous = phi;
  }
  ASSERT_EQ(crossings.size(), 3U);
  const double period = (crossings[2] - crossings[0]) / 2;
  const double small_angle = 2 * kPi * std::sqrt(inertia / mgl);
  std::printf("pendulum: ODE period %.6f s, RK4 reference %.6f s (small-angle %.6f s)\n", period,
              reference_period, small_angle);
  EXPECT_NEAR(period, reference_period, 1e-3 * reference_period);
}

TEST(ArmWorld, ArmatureAddsRotorInertiaAboutTheJointAxis) {
  core::RobotModel model = OneJoint(false);
  model.joints[0].armature = 0.05;
  ArmWorld with(model, core::Environment{});
  with.Step(Effort({1.0}));
  const double alpha = with.State().velocity[0] / with.step_s();
  EXPECT_NEAR(alpha, 1.0 / (AxisInertia(model) + 0.05), 1e-6 * alpha);
  WorldOptions off;
  off.armature = false;
  ArmWorld without(model, core::Environment{}, off);
  without.Step(Effort({1.0}));
  EXPECT_NEAR(without.State().velocity[0] / without.step_s(), 1.0 / AxisInertia(model),
              1e-6 / AxisInertia(model));
}

TEST(ArmWorld, HoldBrakesEveryJointAgainstGravity) {
  ArmWorld world(Puma(), core::Environment{});
  const std::vector<double> q0 = {0.3, 0.4, -0.5, 0.2, 0.6, 0.1};
  world.SetJointState(q0);
  core::ArmCommand hold = Limp(6);
  hold.mode = core::CommandMode::kHold;
  for (int k = 0; k < 2000; ++k) world.Step(hold);
  for (int j = 0; j < 6; ++j) {
    EXPECT_NEAR(world.State().position[static_cast<size_t>(j)], q0[static_cast<size_t>(j)], 1e-9);
    EXPECT_TRUE(world.State().flags[static_cast<size_t>(j)] & sirupp::arm_state_t::FLAG_BRAKED);
  }
}

TEST(ArmWorld, SameInputsGiveBitIdenticalStates) {
  auto run = [] {
    ArmWorld world(Puma(), core::Environment{});
    std::mt19937 random(42);
    std::uniform_real_distribution<double> effort(-3, 3);
    std::vector<double> trace;
    for (int k = 0; k < 3000; ++k) {
      world.Step(Effort({effort(random), effort(random), effort(random), effort(random) / 3,
                         effort(random) / 3, effort(random) / 3}));
      const core::ArmState state = world.State();
      trace.insert(trace.end(), state.position.begin(), state.position.end());
      trace.insert(trace.end(), state.velocity.begin(), state.velocity.end());
    }
    return trace;
  };
  const std::vector<double> first = run();
  const std::vector<double> second = run();
  ASSERT_EQ(first.size(), second.size());
  EXPECT_EQ(std::memcmp(first.data(), second.data(), first.size() * sizeof(double)), 0);
}

core::EnvironmentObject Object(const std::string& name, core::ShapeType type, Eigen::Vector3d size,
                               Eigen::Vector3d position, bool is_static, double mass = 0) {
  core::EnvironmentObject object;
  object.name = name;
  object.shape.type = type;
  object.shape.size_m = size;
  object.shape.pose.position_m = position;
  object.is_static = is_static;
  object.mass_kg = mass;
  return object;
}

TEST(ArmWorld, AFreeBallComesToRestOnAStaticTable) {
  core::Environment environment;
  environment.objects.push_back(
      Object("table", core::ShapeType::kBox, {0.4, 0.4, 0.1}, {0.8, 0, 0.05}, true));
  environment.objects.push_back(
      Object("ball", core::ShapeType::kSphere, {0.03, 0, 0}, {0.8, 0, 0.3}, false, 0.1));
  ArmWorld world(Puma(), environment);
  core::ArmCommand hold = Limp(6);
  hold.mode = core::CommandMode::kHold;
  for (int k = 0; k < 4000; ++k) world.Step(hold);
  const std::vector<ObjectPose> poses = world.ObjectPoses();
  ASSERT_EQ(poses.size(), 2U);
  EXPECT_NEAR(poses[1].pose.translation().z(), 0.1 + 0.03, 2e-3);  // resting on the top
  EXPECT_NEAR(poses[0].pose.translation().z(), 0.05, 1e-12);       // the table never moves
  // Reset puts it back where the file had it.
  world.SetJointState(world.State().position, {}, /*reset_objects=*/true);
  EXPECT_NEAR(world.ObjectPoses()[1].pose.translation().z(), 0.3, 1e-12);
}

TEST(ArmWorld, ALimpArmFallsOntoATableAndStopsThere) {
  core::Environment environment;
  // A table top from z = 0.20 to 0.25 m under the forearm (which points along +x at z ~ 0.33 m).
  environment.objects.push_back(
      Object("table", core::ShapeType::kBox, {0.4, 0.6, 0.05}, {0.35, 0, 0.225}, true));
  core::RobotModel model = Puma();
  ArmWorld with_table(model, environment);
  ArmWorld without_table(model, core::Environment{});
  for (int k = 0; k < 4000; ++k) {
    with_table.Step(Limp(6));
    without_table.Step(Limp(6));
  }
  // Without the table the arm swings far down; with it, every link stays above the top (within
  // the contact's softness).
  double lowest_with = 1e9;
  for (int l = 2; l <= 6; ++l) {
    lowest_with = std::min(lowest_with, with_table.LinkBodyPose(l).translation().z());
  }
  EXPECT_GT(lowest_with, 0.25 - 0.01);
  EXPECT_LT(without_table.LinkBodyPose(3).translation().z(), 0.2);
}

TEST(ArmWorld, AFreeBoxRestsOnAnotherFreeBox) {
  // Free objects collide with each other as well as with static ones.
  core::Environment environment;
  environment.objects.push_back(
      Object("floor", core::ShapeType::kBox, {0.6, 0.6, 0.02}, {0.8, 0, -0.01}, true));
  environment.objects.push_back(
      Object("lower", core::ShapeType::kBox, {0.1, 0.1, 0.1}, {0.8, 0, 0.05}, false, 0.2));
  environment.objects.push_back(
      Object("upper", core::ShapeType::kBox, {0.06, 0.06, 0.06}, {0.8, 0, 0.14}, false, 0.1));
  ArmWorld world(Puma(), environment);
  core::ArmCommand hold = Limp(6);
  hold.mode = core::CommandMode::kHold;
  for (int k = 0; k < 2000; ++k) world.Step(hold);
  const std::vector<ObjectPose> poses = world.ObjectPoses();
  EXPECT_NEAR(poses[1].pose.translation().z(), 0.05, 2e-3);
  EXPECT_NEAR(poses[2].pose.translation().z(), 0.1 + 0.03, 3e-3);  // on the lower box
}

// --- Rest (WorldOptions::rest, docs/physics.md)

core::ArmCommand Hold(int n) {
  core::ArmCommand command = Limp(n);
  command.mode = core::CommandMode::kHold;
  return command;
}

// A PD law on encoder counts, as a PIC-SERVO computes it: the same counts give the same
// command, so a held arm gets one unchanged command and can come to rest.
struct CountsPd {
  std::vector<double> goal;
  std::vector<long> previous;
  core::ArmCommand operator()(const core::ArmState& state) {
    const double quantum = 1e-4;  // rad per count
    std::vector<double> effort;
    previous.resize(goal.size(), 0);
    for (size_t j = 0; j < goal.size(); ++j) {
      const long error = std::lround((goal[j] - state.position[j]) / quantum);
      effort.push_back(0.004 * static_cast<double>(error) +
                       0.05 * static_cast<double>(error - previous[j]));
      previous[j] = error;
    }
    return Effort(effort);
  }
};

// Runs the law until the arm is at rest again (at most 20 000 steps).
void SettleAt(ArmWorld& world, CountsPd& law) {
  int k = 0;
  do {
    world.Step(law(world.State()));
  } while (!world.AtRest() && ++k < 20000);
}

TEST(ArmWorld, AHeldArmComesToRestAndStaysBitForBitStill) {
  ArmWorld world(Puma(), core::Environment{});
  world.SetJointState({0.2, -0.5, 0.8, 0, 0.3, 0}, {0.3, 0, 0, 0, 0, 0});
  EXPECT_FALSE(world.AtRest());  // moving
  int steps = 0;
  while (!world.AtRest() && steps < 2000) {
    world.Step(Hold(6));
    ++steps;
  }
  ASSERT_TRUE(world.AtRest()) << "not at rest after " << steps << " steps";
  const core::ArmState rest = world.State();
  for (int8_t flags : rest.flags) EXPECT_TRUE(flags & sirupp::arm_state_t::FLAG_AT_REST);
  for (double v : rest.velocity) EXPECT_LE(std::abs(v), 1e-6);
  for (int k = 0; k < 5000; ++k) world.Step(Hold(6));
  EXPECT_EQ(world.State().position, rest.position);
  EXPECT_EQ(world.RestTicks(), 5000);
}

TEST(ArmWorld, AMoveFromRestDoesNotDependOnHowLongTheArmRested) {
  // The servo loop's tick of start is up to the scheduler (the plan arrives when it arrives);
  // the arm's motion must not be.
  const std::vector<double> first = {0.1, -0.6, 0.7, 0.1, 0.2, 0.1};
  const std::vector<double> second = {0.6, -0.2, 0.3, -0.2, 0.5, 0.4};
  auto run = [&](int rest_ticks, bool rest) {
    WorldOptions options;
    options.rest = rest;
    ArmWorld world(Puma(), core::Environment{}, options);
    CountsPd law{first, {}};
    if (rest) {
      SettleAt(world, law);
      EXPECT_TRUE(world.AtRest());
    } else {
      for (int k = 0; k < 6000; ++k) world.Step(law(world.State()));
    }
    for (int k = 0; k < rest_ticks; ++k) world.Step(law(world.State()));
    EXPECT_EQ(world.AtRest(), rest);
    law.goal = second;
    for (int k = 0; k < 3000; ++k) world.Step(law(world.State()));
    return world.State().position;
  };
  const std::vector<double> early = run(100, true);
  const std::vector<double> late = run(1001, true);  // odd: the other phase of any trembling
  EXPECT_EQ(early, late);                            // bit for bit
  EXPECT_GT(std::abs(early[0] - first[0]), 0.1);     // it did move
  // Without rest the held arm trembles in its last bits, and where the move ends depends on the
  // tick it started at: what the rest is for.
  EXPECT_NE(run(100, false), run(1001, false));
}

TEST(ArmWorld, AnotherCommandWakesTheArm) {
  ArmWorld world(Puma(), core::Environment{});
  EXPECT_TRUE(world.AtRest());  // built at home, still
  world.Step(Hold(6));
  EXPECT_TRUE(world.AtRest());  // a hold keeps a still arm still
  std::vector<double> effort(6, 0.0);
  effort[0] = 5.0;  // N*m on the waist, above its static friction
  world.Step(Effort(effort));
  EXPECT_FALSE(world.AtRest());
  for (int k = 0; k < 200; ++k) world.Step(Effort(effort));
  EXPECT_GT(world.State().position[0], 1e-4);
  EXPECT_FALSE(world.AtRest());
}

TEST(ArmWorld, FreeObjectsKeepTheArmAwake) {
  core::Environment environment;
  environment.objects.push_back(
      Object("box", core::ShapeType::kBox, {0.1, 0.1, 0.1}, {0.8, 0, 0.5}, false, 0.2));
  ArmWorld world(Puma(), environment);
  EXPECT_FALSE(world.AtRest());
  for (int k = 0; k < 1000; ++k) world.Step(Hold(6));
  EXPECT_FALSE(world.AtRest());
  EXPECT_LT(world.ObjectPoses()[0].pose.translation().z(), 0.5 - 0.01);  // the box fell
}

// The limit's number of static objects (2 cm cubes on the floor, rows of 100) with a table top
// under the forearm in the middle of them.
core::Environment ManyStaticBoxesAndATable() {
  core::Environment environment;
  for (size_t i = 0; i + 1 < core::kMaxStaticObjects; ++i) {
    environment.objects.push_back(Object("box" + std::to_string(i), core::ShapeType::kBox,
                                         {0.02, 0.02, 0.02},
                                         {0.35 + 0.04 * static_cast<double>(i / 100),
                                          -2.0 + 0.04 * static_cast<double>(i % 100), 0.01},
                                         true));
    if (i == core::kMaxStaticObjects / 2) {
      environment.objects.push_back(
          Object("table", core::ShapeType::kBox, {0.4, 0.6, 0.05}, {0.35, 0, 0.225}, true));
    }
  }
  return environment;
}

TEST(ArmWorld, TenThousandStaticObjectsStepFasterThanRealTime) {
  const core::Environment environment = ManyStaticBoxesAndATable();
  ASSERT_EQ(environment.objects.size(), core::kMaxStaticObjects);
  ArmWorld world(Puma(), environment);
  // Static objects were tested against each other every step: 0.54 s per step with 10 000 of
  // them. Now the step must stay well within the servo tick of real time (0.512 ms; measured
  // about 0.03 ms) on average over a second of simulated time, a generous bound on a busy
  // machine.
  const int steps = 2000;
  const auto start = std::chrono::steady_clock::now();
  for (int k = 0; k < steps; ++k) world.Step(Limp(6));
  const double per_step =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() / steps;
  EXPECT_LT(per_step, world.step_s()) << per_step * 1e3 << " ms per step";
  // The contacts still work: the limp arm came down onto the table among the boxes.
  double lowest = 1e9;
  for (int l = 2; l <= 6; ++l) lowest = std::min(lowest, world.LinkBodyPose(l).translation().z());
  EXPECT_GT(lowest, 0.25 - 0.01);
}

// SIM_COMMAND LOAD_MODEL's physics part: another model of the same arm replaces the running one
// at the joints' present positions, time going on; one the arm cannot take (another joint count,
// a joint outside the new limits, a bad file) is refused naming why, the old arm kept.
TEST(ArmWorldReplaceModel, TakesTheNewModelWhereTheArmStandsOrRefusesAndKeepsTheOld) {
  const core::RobotModel puma = Puma();
  core::Environment none;
  ArmWorld world(puma, none);
  world.SetJointState({0.3, -0.2, 0.1, 0, 0.4, 0});
  core::ArmCommand hold = Limp(6);
  hold.mode = core::CommandMode::kHold;
  for (int i = 0; i < 10; ++i) world.Step(hold);
  const int64_t tick = world.tick();
  const std::vector<double> q = world.State().position;

  core::RobotModel heavier = puma;
  heavier.links[2].mass_kg *= 1.5;
  heavier.source_hash = "0123456789abcdef";
  world.ReplaceModel(heavier);
  EXPECT_EQ(world.model().source_hash, "0123456789abcdef");
  EXPECT_DOUBLE_EQ(world.model().links[2].mass_kg, heavier.links[2].mass_kg);
  EXPECT_EQ(world.tick(), tick);
  for (size_t j = 0; j < q.size(); ++j) EXPECT_DOUBLE_EQ(world.State().position[j], q[j]);
  world.Step(hold);
  EXPECT_EQ(world.tick(), tick + 1);

  core::RobotModel narrow = puma;
  narrow.joints[0].position_max = 0.2;  // joint 1 stands at 0.3
  try {
    world.ReplaceModel(narrow);
    ADD_FAILURE() << "a joint outside the new limits was taken";
  } catch (const std::invalid_argument& error) {
    EXPECT_NE(std::string(error.what()).find("joints[0]"), std::string::npos) << error.what();
    EXPECT_NE(std::string(error.what()).find("outside the limits"), std::string::npos)
        << error.what();
  }
  core::RobotModel two = core::LoadRobotModel("tests/data/good_two_link.yaml");
  EXPECT_THROW(world.ReplaceModel(two), std::invalid_argument);
  EXPECT_EQ(world.model().source_hash, "0123456789abcdef");  // kept
  EXPECT_NEAR(world.State().position[0], q[0], 1e-6);

  // Through the text, as sirupp-sim gets it: a bad file names its line.
  try {
    LoadModelText(world, "name: x\nunits: {length: m, angle: rad}\njoints: 3\n", "bad.yaml");
    ADD_FAILURE() << "a bad model file was taken";
  } catch (const core::ConfigError& error) {
    EXPECT_NE(std::string(error.what()).find("bad.yaml:"), std::string::npos) << error.what();
  }
  EXPECT_EQ(world.model().source_hash, "0123456789abcdef");
}

// A free object keeps its pose and speed through a model load: a falling box goes on falling
// from where it was, exactly as in a twin world that kept its model.
TEST(ArmWorldReplaceModel, FreeObjectsStayWhereTheyAreMovingAsTheyWere) {
  core::Environment environment;
  environment.objects.push_back(
      Object("box", core::ShapeType::kBox, {0.1, 0.1, 0.1}, {0.8, 0, 0.5}, false, 0.2));
  ArmWorld world(Puma(), environment);
  ArmWorld twin(Puma(), environment);
  for (int k = 0; k < 300; ++k) {
    world.Step(Hold(6));
    twin.Step(Hold(6));
  }
  const double z = world.ObjectPoses()[0].pose.translation().z();
  ASSERT_LT(z, 0.5 - 0.01);  // falling
  core::RobotModel heavier = Puma();
  heavier.links[2].mass_kg *= 1.5;
  world.ReplaceModel(heavier);
  EXPECT_DOUBLE_EQ(world.ObjectPoses()[0].pose.translation().z(), z);  // not back at 0.5
  for (int k = 0; k < 20; ++k) {
    world.Step(Hold(6));
    twin.Step(Hold(6));
  }
  EXPECT_LT(world.ObjectPoses()[0].pose.translation().z(), z);
  EXPECT_NEAR(world.ObjectPoses()[0].pose.translation().z(),
              twin.ObjectPoses()[0].pose.translation().z(), 1e-9);  // the same speed
}

}  // namespace
}  // namespace sirupp::sim
