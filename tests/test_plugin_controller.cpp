// Student controller libraries (control/plugin_controller.hpp) in sirupp-control's logic, driving
// sirupp-sim's logic in lockstep on one in-process memq:// bus: the example controllers reach a
// joint target, see the model's dynamics, and libraries that break the rules are refused (when
// loading) or stopped with the arm held (when running).

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <sirupp/arm_command_t.hpp>
#include <sirupp/arm_state_t.hpp>
#include <sirupp/controller_status_t.hpp>
#include <sirupp/joint_target_t.hpp>
#include <string>
#include <vector>

#include "control/control_node.hpp"
#include "control/plugin_controller.hpp"
#include "core/dynamics.hpp"
#include "core/model_loader.hpp"
#include "sim/sim_node.hpp"
#include "tests/helpers.hpp"

namespace sirupp::control {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180;
// Built by examples/CMakeLists.txt and tests/CMakeLists.txt; paths from the build.
const std::string kPdGravity = SIRUPP_PD_GRAVITY_LIB;
const std::string kComputedTorque = SIRUPP_COMPUTED_TORQUE_LIB;
const std::string kTestControllers = SIRUPP_TEST_CONTROLLER_DIR;

struct Rig {
  core::RobotModel model = core::LoadRobotModel("config/robots/puma260.yaml");
  core::Bus bus{"memq://"};
  sim::ArmWorld world{model, core::Environment{}};  // friction on, as sirupp-sim runs
  sim::SimNode sim{bus, world, core::Environment{}, sim::NodeOptions{}};  // lockstep
  ControlNode control;

  Rig(const std::string& library, const std::string& args)
      : control(bus, model, Options(library, args, model)) {}

  static ControlOptions Options(const std::string& library, const std::string& args,
                                const core::RobotModel& model) {
    ControlOptions options;
    options.effort_law = std::make_shared<PluginEffortLaw>(library, args, model);
    return options;
  }
  void RunFor(double seconds) {
    const double until = world.time_s() + seconds;
    for (int k = 0; k < 10000000 && world.time_s() < until; ++k) sim.Service(0);
  }
};

TEST(PluginController, TheExampleControllersReachAJointTargetInLockstep) {
  // Stated tolerance: 0.5 degree on every joint after 4 s (the moves take at most 1.4 s; static
  // friction, which neither example compensates, stops each joint a little short).
  const std::vector<double> target_deg = {30, -20, 40, 25, -30, 45};
  for (const std::string& library : {kPdGravity, kComputedTorque}) {
    Rig rig(library, "");
    rig.RunFor(0.01);  // the servos (and the controller) come on with the first state
    sirupp::joint_target_t target{};
    target.num_joints = 6;
    for (double degrees : target_deg) target.position.push_back(degrees * kDeg);
    target.max_velocity.assign(6, 0.0);
    target.acceleration.assign(6, 0.0);
    target.active.assign(6, 1);
    rig.bus.Publish("ARM_TARGET", target);
    rig.RunFor(4.0);
    std::printf("%s: final error (deg)", library.substr(library.find_last_of('/') + 1).c_str());
    for (int j = 0; j < 6; ++j) {
      const double error = rig.world.State().position[static_cast<size_t>(j)] / kDeg -
                           target_deg[static_cast<size_t>(j)];
      std::printf(" %+.3f", error);
      EXPECT_LT(std::abs(error), 0.5) << library << " joint " << j + 1;
    }
    std::printf("\n");
    EXPECT_EQ(rig.control.last_error(), "") << library;
    EXPECT_EQ(rig.control.state(), sirupp::controller_status_t::STATE_IDLE) << library;
    EXPECT_EQ(rig.sim.counters().lockstep_timeouts, 0) << library;
    EXPECT_EQ(rig.control.states_answered(), rig.world.tick()) << library;
  }
}

// One tick of a law, called directly, at a given state and set-points.
std::vector<double> EffortAt(PluginEffortLaw& law, const core::JointVector& q,
                             const core::JointVector& qd, const core::JointVector& setpoint,
                             const core::JointVector& setpoint_velocity,
                             const core::JointVector& setpoint_acceleration) {
  core::ArmState state;
  state.position.assign(q.data(), q.data() + q.size());
  state.velocity.assign(qd.data(), qd.data() + qd.size());
  state.effort.assign(static_cast<size_t>(q.size()), 0.0);
  state.flags.assign(static_cast<size_t>(q.size()), 0);
  ControlInput input;
  input.state = &state;
  input.setpoint_position.assign(setpoint.data(), setpoint.data() + setpoint.size());
  input.setpoint_velocity.assign(setpoint_velocity.data(),
                                 setpoint_velocity.data() + setpoint_velocity.size());
  input.setpoint_acceleration.assign(setpoint_acceleration.data(),
                                     setpoint_acceleration.data() + setpoint_acceleration.size());
  input.goal = input.setpoint_position;
  law.Reset(input);
  std::vector<double> effort;
  law.Update(input, effort);
  return effort;
}

TEST(PluginController, TheControllerSeesTheModelsDynamicsAtTheMeasuredState) {
  const core::RobotModel model = core::LoadRobotModel("config/robots/puma260.yaml");
  const core::Dynamics dynamics(model);
  const core::JointVector q = core::ToJointVector({0.3, -0.4, 0.9, 0.2, -0.6, 0.1});
  const core::JointVector qd = core::ToJointVector({0.5, -0.3, 0.8, 1.2, -0.7, 2.0});
  const core::JointVector qdd = core::ToJointVector({1.0, -2.0, 3.0, -4.0, 5.0, -6.0});
  const core::JointVector zero = core::JointVector::Zero(6);

  // PD + gravity on its set-point at rest: only the gravity effort is left.
  PluginEffortLaw pd(kPdGravity, "", model);
  EXPECT_EQ(pd.name(), "pd_gravity.so");
  const std::vector<double> hold = EffortAt(pd, q, zero, q, zero, zero);
  const core::JointVector gravity = dynamics.GravityEffort(q);
  for (int j = 0; j < 6; ++j) EXPECT_NEAR(hold[static_cast<size_t>(j)], gravity[j], 1e-12) << j;

  // Computed torque exactly on its trajectory: M(q) qdd + bias(q, qd), which is inverse dynamics
  // (so the mass matrix reached the library row-major and the bias with the Coriolis terms).
  PluginEffortLaw computed(kComputedTorque, "", model);
  const std::vector<double> effort = EffortAt(computed, q, qd, q, qd, qdd);
  const core::JointVector expected = dynamics.InverseDynamics(q, qd, qdd);
  for (int j = 0; j < 6; ++j) {
    EXPECT_NEAR(effort[static_cast<size_t>(j)], expected[j], 1e-12) << j;
  }
}

TEST(PluginController, UnusableLibrariesAreRefusedNamingTheFileAndTheProblem) {
  const core::RobotModel model = core::LoadRobotModel("config/robots/puma260.yaml");
  auto load_error = [&model](const std::string& library, const std::string& args) {
    return sirupp::testing::ErrorText<ControllerLoadError>(
        [&] { PluginEffortLaw law(library, args, model); });
  };
  std::string error = load_error("/nonexistent/controller.so", "");
  EXPECT_NE(error.find("/nonexistent/controller.so: cannot load the controller library: "),
            std::string::npos)
      << error;

  error = load_error(kTestControllers + "/no_factory.so", "");
  EXPECT_NE(error.find("no_factory.so: not a SIRUPP controller: no symbol "
                       "sirupp_controller_create and sirupp_controller_destroy; export the "
                       "factory functions with SIRUPP_EXPORT_CONTROLLER(YourClass)"),
            std::string::npos)
      << error;

  error = load_error(kTestControllers + "/wrong_abi.so", "");
  EXPECT_NE(error.find("wrong_abi.so: built against controller ABI version " +
                       std::to_string(SIRUPP_CONTROLLER_ABI_VERSION + 1) +
                       ", this sirupp-control needs version " +
                       std::to_string(SIRUPP_CONTROLLER_ABI_VERSION)),
            std::string::npos)
      << error;

  error = load_error(kPdGravity, "wn=100 gain=3");
  EXPECT_NE(error.find("pd_gravity.so: the controller refused its arguments 'wn=100 gain=3': "
                       "unknown argument 'gain' (allowed: wn, zeta)"),
            std::string::npos)
      << error;

  // A ConfigError, so process mains print it on one line and exit 2.
  EXPECT_NE(sirupp::testing::ErrorText<core::ConfigError>(
                [&] { PluginEffortLaw law(kTestControllers + "/wrong_abi.so", "", model); }),
            "");
}

TEST(PluginController, ANonFiniteEffortHoldsTheArmAndReportsAFaultNamingTheController) {
  Rig rig(kTestControllers + "/nan_effort.so", "200");  // NaN on joint 2 from tick 200
  sirupp::controller_status_t last_status{};
  rig.bus.Subscribe<sirupp::controller_status_t>(
      "CONTROLLER_STATUS", [&](const sirupp::controller_status_t& status,
                               const core::ReceiveInfo&) { last_status = status; });
  int holds = 0, efforts_after_fault = 0;
  rig.bus.Subscribe<sirupp::arm_command_t>(
      "SIM_ARM_COMMAND", [&](const sirupp::arm_command_t& command, const core::ReceiveInfo&) {
        if (command.mode == sirupp::arm_command_t::MODE_HOLD) ++holds;
        if (command.tick >= 200 && command.mode == sirupp::arm_command_t::MODE_EFFORT) {
          ++efforts_after_fault;
        }
      });
  rig.RunFor(0.1);  // tick 195: still under the gravity efforts
  EXPECT_EQ(rig.control.state(), sirupp::controller_status_t::STATE_IDLE);
  rig.RunFor(0.4);
  const std::vector<double> held = rig.world.State().position;
  rig.RunFor(0.5);

  EXPECT_EQ(rig.control.state(), sirupp::controller_status_t::STATE_FAULT);
  const std::string& error = rig.control.last_error();
  EXPECT_NE(error.find("controller 'nan_effort.so' at tick 200"), std::string::npos) << error;
  EXPECT_NE(error.find("for joint 2"), std::string::npos) << error;
  EXPECT_EQ(last_status.state, sirupp::controller_status_t::STATE_FAULT);
  EXPECT_EQ(last_status.last_error, error);
  // Every answer from tick 200 on brakes the arm, and it stays where it was braked.
  EXPECT_EQ(efforts_after_fault, 0);
  EXPECT_EQ(holds, rig.control.states_answered() - 200);
  const core::ArmState state = rig.world.State();
  for (int j = 0; j < 6; ++j) {
    const auto i = static_cast<size_t>(j);
    EXPECT_TRUE(state.flags[i] & sirupp::arm_state_t::FLAG_BRAKED) << j;
    EXPECT_NEAR(state.position[i], held[i], 1e-6) << j;
  }
}

}  // namespace
}  // namespace sirupp::control
