#include "python/python_law.hpp"

#include <pybind11/numpy.h>

#include <algorithm>
#include <stdexcept>

#include "control/plugin_controller.hpp"
#include "python/convert.hpp"

namespace sirupp::python {

namespace py = pybind11;

PythonEffortLaw::PythonEffortLaw(const std::string& file, const std::string& args,
                                 const core::RobotModel& model)
    : dynamics_(model), n_(model.num_joints()) {
  const size_t slash = file.find_last_of('/');
  name_ = slash == std::string::npos ? file : file.substr(slash + 1);
  try {
    const py::module_ controllers = py::module_::import("sirupp.controllers");
    state_class_ = controllers.attr("State");
    fault_class_ = controllers.attr("ControllerFault");
    fault_text_ = controllers.attr("fault_text");
    std::vector<double> effort_max, lower, upper;
    for (const core::Joint& joint : model.joints) {
      effort_max.push_back(joint.effort_max);
      lower.push_back(joint.position_min);
      upper.push_back(joint.position_max);
    }
    Eigen::MatrixXd qlim(2, n_);
    for (int i = 0; i < n_; ++i) {
      qlim(0, i) = lower[static_cast<size_t>(i)];
      qlim(1, i) = upper[static_cast<size_t>(i)];
    }
    const py::object arm = controllers.attr("ArmInfo")(n_, model.name, model.servo_tick_s,
                                                       ToArray(effort_max), ToArray(qlim));
    runner_ = controllers.attr("Runner")(file, args, arm);
  } catch (py::error_already_set& error) {
    std::string text = fault_text_ ? std::string(py::str(fault_text_(error.value())))
                                   : std::string(py::str(error.value()));
    if (!error.matches(PyExc_FileNotFoundError)) text = "cannot load it: " + text;
    throw control::ControllerLoadError(file, text);
  }
}

PythonEffortLaw::~PythonEffortLaw() {
  // The objects go before the interpreter does (the host's scoped_interpreter outlives this law).
  runner_ = py::object();
  state_class_ = py::object();
  fault_class_ = py::object();
  fault_text_ = py::object();
}

py::object PythonEffortLaw::Call(bool reset, const control::ControlInput& input) {
  const core::ArmState& measured = *input.state;
  const Eigen::Map<const Eigen::VectorXd> q(measured.position.data(), n_);
  const Eigen::Map<const Eigen::VectorXd> qd(measured.velocity.data(), n_);
  const Eigen::VectorXd gravity = dynamics_.GravityEffort(q);
  const Eigen::VectorXd bias = dynamics_.BiasEffort(q, qd);
  try {
    const py::object state = state_class_(
        input.time_s, input.tick, ToArray(measured.position), ToArray(measured.velocity),
        ToArray(measured.effort), ToArray(input.setpoint_position),
        ToArray(input.setpoint_velocity), ToArray(input.setpoint_acceleration), ToArray(input.goal),
        ToArray(gravity), ToArray(bias), ToArray(dynamics_.MassMatrix(q)));
    return runner_.attr("call")(reset, state);
  } catch (py::error_already_set& error) {
    // Runner turns the student's exceptions into ControllerFault with the traceback's last line;
    // anything else (a bug of ours, MemoryError) is described the same way.
    const std::string text = error.matches(fault_class_)
                                 ? std::string(py::str(error.value()))
                                 : std::string(py::str(fault_text_(error.value())));
    throw std::runtime_error(text);
  }
}

void PythonEffortLaw::Reset(const control::ControlInput& input) { Call(true, input); }

void PythonEffortLaw::Update(const control::ControlInput& input, std::vector<double>& effort) {
  const py::object answer = Call(false, input);
  const auto array = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(answer);
  if (!array || array.ndim() != 1 || array.shape(0) != n_) {
    throw std::runtime_error("update returned no array of " + std::to_string(n_) + " efforts");
  }
  effort.assign(array.data(), array.data() + n_);
}

}  // namespace sirupp::python
