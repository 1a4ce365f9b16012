// sirupp.run_process_controller's loop (python/sirupp/controllers.py): a controller in its own
// process, answering every SIM_ARM_STATE with an arm_command_t of the same tick, like
// examples/05_cpp_process_controller, so sirupp-sim can run in lockstep with it. The transport and
// the arm's dynamics are C++ (core::Bus, core::Dynamics); the law is the Python step function.
//
// Messages are handled with the GIL released (in slices, with a signal check between them) and
// only queued; the Python step runs afterwards, with the GIL, on this thread. A step that raises
// or returns bad efforts is answered with HOLD for that tick (the sim brakes the arm), then the
// exception ends the loop.
#include <pybind11/stl.h>

#include <chrono>
#include <cmath>
#include <deque>
#include <memory>
#include <optional>
#include <sirupp/arm_state_t.hpp>
#include <sirupp/robot_model_t.hpp>
#include <string>

#include "core/arm_state.hpp"
#include "core/bus.hpp"
#include "core/channels.hpp"
#include "core/dynamics.hpp"
#include "core/errors.hpp"
#include "core/robot_model.hpp"
#include "core/translate.hpp"
#include "python/bindings.hpp"
#include "python/convert.hpp"

namespace sirupp::python {

namespace {

using Clock = std::chrono::steady_clock;

py::dict RunProcessController(const py::object& make, const std::string& name,
                              const std::string& lcm_url, const std::string& prefix,
                              double stale_s) {
  if (!(stale_s > 0)) throw py::value_error("stale_s: must be > 0");
  std::unique_ptr<core::Bus> bus;
  try {
    bus = std::make_unique<core::Bus>(lcm_url, prefix);
  } catch (const std::exception& error) {
    throw RigError(std::string("cannot join the rig's bus: ") + error.what());
  }
  const core::Channels channels;
  std::optional<core::RobotModel> model;
  std::string model_problem;
  std::deque<sirupp::arm_state_t> states;
  bus->Subscribe(channels.robot_model,
                 std::function<void(const sirupp::robot_model_t&, const core::ReceiveInfo&)>(
                     [&](const sirupp::robot_model_t& m, const core::ReceiveInfo& info) {
                       if (model) return;
                       try {
                         model = core::RobotModelFromMessage(m, info.channel);
                       } catch (const std::exception& error) {
                         model_problem = error.what();
                       }
                     }));
  bus->Subscribe(
      channels.sim_arm_state,
      std::function<void(const sirupp::arm_state_t&, const core::ReceiveInfo&)>(
          [&](const sirupp::arm_state_t& m, const core::ReceiveInfo&) { states.push_back(m); }),
      1000);

  std::unique_ptr<core::Dynamics> dynamics;
  py::object step;
  int n = 0;
  int64_t ticks = 0, seq = 0;
  std::vector<double> last_q;
  Clock::time_point last_state = Clock::now();
  bool heard = false;

  // The answer to a state: its efforts, or HOLD (brakes on) with zero efforts.
  auto publish = [&](const core::ArmState& state, bool hold, const std::vector<double>& effort) {
    core::ArmCommand command;
    command.utime = state.utime;
    command.tick = state.tick;
    command.sender = name;
    command.mode = hold ? core::CommandMode::kHold : core::CommandMode::kEffort;
    command.effort = hold ? std::vector<double>(static_cast<size_t>(n), 0.0) : effort;
    bus->Publish(channels.sim_arm_command, core::ToMessage(command, seq++));
  };

  for (;;) {
    {
      py::gil_scoped_release release;
      bus->Handle(20);
      bus->HandleAvailable();
    }
    if (PyErr_CheckSignals() != 0) throw py::error_already_set();
    if (!model_problem.empty()) throw RigError("ROBOT_MODEL refused: " + model_problem);
    if (model && !dynamics) {
      n = model->num_joints();
      dynamics = std::make_unique<core::Dynamics>(*model);
      py::dict info;
      info["name"] = model->name;
      info["n"] = n;
      info["servo_tick_s"] = model->servo_tick_s;
      std::vector<double> effort_max, lower, upper;
      for (const core::Joint& joint : model->joints) {
        effort_max.push_back(joint.effort_max);
        lower.push_back(joint.position_min);
        upper.push_back(joint.position_max);
      }
      info["effort_max"] = ToArray(effort_max);
      Eigen::MatrixXd qlim(2, n);
      for (int i = 0; i < n; ++i) {
        qlim(0, i) = lower[static_cast<size_t>(i)];
        qlim(1, i) = upper[static_cast<size_t>(i)];
      }
      info["qlim"] = ToArray(qlim);
      step = make(info);
    }
    // Without the model no state is answered: in lockstep the sim waits and sends it again.
    while (dynamics && !states.empty()) {
      const sirupp::arm_state_t message = states.front();
      states.pop_front();
      heard = true;
      last_state = Clock::now();
      core::ArmState state;
      try {  // counts, finiteness, and the joint count against the model on ROBOT_MODEL
        state = core::ArmStateFromMessage(message, bus->FullName(channels.sim_arm_state), n);
      } catch (const core::MessageError& error) {
        throw RigError(error.what());
      }
      const Eigen::VectorXd q = Eigen::Map<const Eigen::VectorXd>(state.position.data(), n);
      const Eigen::VectorXd qd = Eigen::Map<const Eigen::VectorXd>(state.velocity.data(), n);
      std::vector<double> effort;
      try {
        const py::object answer = step(
            state.tick, static_cast<double>(state.utime) * 1e-6, ToArray(state.position),
            ToArray(state.velocity), ToArray(state.effort), ToArray(dynamics->GravityEffort(q)),
            ToArray(dynamics->BiasEffort(q, qd)), ToArray(dynamics->MassMatrix(q)));
        const Eigen::VectorXd e = VectorArg(answer, n, "update's efforts", "one per joint");
        effort.assign(e.data(), e.data() + n);
      } catch (...) {
        publish(state, true, {});
        throw;
      }
      publish(state, false, effort);
      ++ticks;
      last_q = state.position;
    }
    const double quiet = std::chrono::duration<double>(Clock::now() - last_state).count();
    if (heard && quiet > stale_s) break;
  }
  py::dict result;
  result["ticks"] = ticks;
  result["q"] = ToArray(last_q);
  return result;
}

}  // namespace

void BindProcessController(py::module_& m) {
  m.def("_run_process_controller", &RunProcessController, py::arg("make"), py::arg("name"),
        py::arg("lcm_url"), py::arg("prefix"), py::arg("stale_s"),
        "the loop of sirupp.run_process_controller (use that)");
}

}  // namespace sirupp::python
