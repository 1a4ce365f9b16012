// Identification (lab/identify.hpp) on synthetic data with known parameters: a "real" arm that is
// the model with other friction and armature on joints 1-3 follows a set-point that sweeps speeds
// and directions; identifying from the model's own values brings the simulated angles closer to
// the data. Issue 20 asks for the parameters within 5 %; the present search does not get there
// (measured recovery errors 5-60 % after 400 simulations, docs/emulator-fit.md), so this test
// checks the error reduction and prints the recovered values beside the true ones.

#include <gtest/gtest.h>

#include <cmath>

#include "core/model_loader.hpp"
#include "lab/identify.hpp"

namespace sirupp::lab {
namespace {

constexpr double kPi = 3.14159265358979323846;

// A set-point for joints 1-3: sums of sines (speeds from 0 to about 60 deg/s, both ways).
logger::RunTable Sweep(const core::RobotModel& model, double seconds, double phase) {
  logger::RunTable table;
  std::vector<logger::JointInfo> joints;
  for (const core::Joint& j : model.joints) joints.push_back({j.name, false});
  table.Reset(joints);
  table.label = "sweep";
  table.source = "synthetic";
  const auto rows = static_cast<size_t>(seconds / model.servo_tick_s);
  for (size_t k = 0; k < rows; ++k) {
    const double t = static_cast<double>(k) * model.servo_tick_s;
    table.time_s.push_back(t);
    table.move_id.push_back(1);
    for (size_t j = 0; j < joints.size(); ++j) {
      const double a = j < 3 ? 1.0 + 0.3 * static_cast<double>(j) : 0.0;
      const double deg = j < 3 ? 20 * std::sin(a * t + phase) + 8 * std::sin(3.1 * a * t) : 0.0;
      table.position[j][0].push_back(deg);
      table.position[j][1].push_back(std::nan(""));
      table.position[j][2].push_back(std::nan(""));
      table.done[j].push_back(0);
    }
    for (size_t s = 0; s < logger::kNumStreams; ++s) table.age_s[s].push_back(0);
  }
  return table;
}

TEST(Identify, FitsSyntheticDataWithKnownParametersCloser) {
  const core::RobotModel model = core::LoadRobotModel("config/robots/puma260.yaml");
  core::RobotModel truth = model;
  const double factors[3][6] = {{1.4, 1.3, 1.5, 1.8, 1.0, 1.25},
                                {0.8, 0.9, 1.2, 1.5, 1.0, 0.8},
                                {1.3, 1.1, 1.0, 0.7, 1.0, 1.3}};
  for (size_t j = 0; j < 3; ++j) {
    core::Friction& f = truth.joints[j].friction;
    f.static_effort *= factors[j][0];
    f.coulomb_positive = std::min(f.coulomb_positive * factors[j][1], f.static_effort);
    f.coulomb_negative = std::min(f.coulomb_negative * factors[j][2], f.static_effort);
    f.viscous *= factors[j][3];
    f.stribeck_velocity = 5 * kPi / 180;  // 5 deg/s: a peak the sweep's slow passes resolve
    truth.joints[j].armature *= factors[j][5];
  }
  std::vector<logger::RunTable> data = {SimulateRealStream(truth, Sweep(model, 4, 0))};
  IdentifyOptions options;
  options.joints = {1, 2, 3};
  options.max_evaluations = 60;
  const IdentifyResult result = Identify(model, data, options);
  ASSERT_EQ(result.joints.size(), 3U);
  for (const JointIdentification& id : result.joints) {
    const auto j = static_cast<size_t>(id.joint - 1);
    const core::Friction& want = truth.joints[j].friction;
    const core::Friction& got = id.friction_after;
    std::printf(
        "joint %d: rms %.4f -> %.5f deg; static %.4f (%.4f) coulomb %.4f/%.4f "
        "(%.4f/%.4f) viscous %.4f (%.4f) stribeck %.5f (%.5f) armature %.5f (%.5f)\n",
        id.joint, id.rms_before_deg, id.rms_after_deg, got.static_effort, want.static_effort,
        got.coulomb_positive, got.coulomb_negative, want.coulomb_positive, want.coulomb_negative,
        got.viscous, want.viscous, got.stribeck_velocity, want.stribeck_velocity, id.armature_after,
        truth.joints[j].armature);
    EXPECT_LT(id.rms_after_deg, 0.75 * id.rms_before_deg) << "joint " << id.joint;
  }
}

}  // namespace
}  // namespace sirupp::lab
