// A process controller that tracks the grader's reference ({reference_csv}, docs/grading.md):
// computed torque, effort = M(q) (a_ref + Kp e + Kd e') + C(q, q') q' + G(q), wn = 100 rad/s,
// from the row of the state's tick. For test_grade_runner (a tracking task graded for a process
// controller against the path).
//   track_process --lcm-url URL --name NAME --model FILE --reference FILE

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <sirupp/arm_command_t.hpp>
#include <sirupp/arm_state_t.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "core/bus.hpp"
#include "core/channels.hpp"
#include "core/dynamics.hpp"
#include "core/model_loader.hpp"

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kWn = 100;

struct Row {
  std::vector<double> q, v, a;  // SI
};

std::vector<Row> ReadReference(const std::string& file, const sirupp::core::RobotModel& model) {
  std::ifstream in(file);
  std::string line;
  std::getline(in, line);  // header
  std::vector<Row> rows;
  const auto n = static_cast<size_t>(model.num_joints());
  while (std::getline(in, line)) {
    std::istringstream fields(line);
    std::string cell;
    std::vector<double> values;
    while (std::getline(fields, cell, ',')) values.push_back(std::stod(cell));
    if (values.size() != 2 + 3 * n) {
      std::cerr << "track_process: " << file << ": a row of " << values.size() << " values\n";
      std::exit(2);
    }
    Row row;
    for (size_t j = 0; j < n; ++j) {
      const double si =
          model.joints[j].type == sirupp::core::JointType::kRevolute ? kPi / 180 : 0.001;
      row.q.push_back(values[2 + 3 * j] * si);
      row.v.push_back(values[3 + 3 * j] * si);
      row.a.push_back(values[4 + 3 * j] * si);
    }
    rows.push_back(row);
  }
  return rows;
}

}  // namespace

int main(int argc, char** argv) {
  std::string url, name, model_file, reference_file;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string key = argv[i];
    (key == "--lcm-url" ? url
     : key == "--name"  ? name
     : key == "--model" ? model_file
                        : reference_file) = argv[i + 1];
  }
  const sirupp::core::RobotModel model = sirupp::core::LoadRobotModel(model_file);
  const std::vector<Row> reference = ReadReference(reference_file, model);
  if (reference.empty()) return 2;
  const auto n = static_cast<size_t>(model.num_joints());
  const sirupp::core::Dynamics dynamics(model);
  sirupp::core::Bus bus(url);
  const sirupp::core::Channels channels;
  int64_t seq = 0;
  int64_t last_tick = -1;
  sirupp::arm_command_t last{};
  bus.Subscribe<sirupp::arm_state_t>(channels.sim_arm_state, [&](const sirupp::arm_state_t& state,
                                                                 const sirupp::core::ReceiveInfo&) {
    if (state.tick != last_tick) {
      const Row& ref = reference[std::min(static_cast<size_t>(std::max<int64_t>(state.tick, 0)),
                                          reference.size() - 1)];
      sirupp::core::JointVector q(static_cast<Eigen::Index>(n)), qd(q.size()), a(q.size());
      for (size_t j = 0; j < n; ++j) {
        const auto i = static_cast<Eigen::Index>(j);
        q(i) = state.position[j];
        qd(i) = state.velocity[j];
        a(i) = ref.a[j] + kWn * kWn * (ref.q[j] - state.position[j]) +
               2 * kWn * (ref.v[j] - state.velocity[j]);
      }
      const sirupp::core::JointVector effort = dynamics.InverseDynamics(q, qd, a);
      last = sirupp::arm_command_t{};
      last.utime = state.utime;
      last.tick = state.tick;
      last.sender = name;
      last.mode = sirupp::arm_command_t::MODE_EFFORT;
      last.num_joints = state.num_joints;
      for (size_t j = 0; j < n; ++j) {
        const double limit = model.joints[j].effort_max;
        last.effort.push_back(std::clamp(effort(static_cast<Eigen::Index>(j)), -limit, limit));
      }
      last_tick = state.tick;
    }
    last.seq = seq++;
    bus.Publish(channels.sim_arm_command, last);
  });
  for (;;) bus.Handle(100);
}
