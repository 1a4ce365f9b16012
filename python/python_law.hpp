#pragma once
// A controller written in Python as the EffortLaw of sirupp-python-controller-host: the embedded
// interpreter imports the student's file through sirupp.controllers (python/sirupp/controllers.py)
// and calls its reset/update each tick with a sirupp.State (measured state, the profiles'
// set-points, and the dynamics G, bias, M computed here by core::Dynamics, as PluginEffortLaw
// does for a library). An exception, a wrong number of efforts or a non-finite one is thrown as
// std::runtime_error with the Python traceback's last line ("ZeroDivisionError: division by zero
// (my_controller.py:12 in update)"), which sirupp-control latches as its fault.
//
// Needs a running interpreter (pybind11::scoped_interpreter) and the GIL on the calling thread.

#include <pybind11/pybind11.h>

#include <string>
#include <vector>

#include "control/effort_law.hpp"
#include "core/dynamics.hpp"
#include "core/robot_model.hpp"

namespace sirupp::python {

class PythonEffortLaw : public control::EffortLaw {
 public:
  // Imports `file` with `args` for `model`; throws control::ControllerLoadError naming the file
  // and the Python error (the traceback's last line) when it cannot.
  PythonEffortLaw(const std::string& file, const std::string& args, const core::RobotModel& model);
  ~PythonEffortLaw() override;

  const std::string& name() const override { return name_; }
  void Reset(const control::ControlInput& input) override;
  void Update(const control::ControlInput& input, std::vector<double>& effort) override;

 private:
  pybind11::object Call(bool reset, const control::ControlInput& input);

  std::string name_;
  core::Dynamics dynamics_;
  int n_ = 0;
  pybind11::object state_class_;  // sirupp.controllers.State
  pybind11::object runner_;       // sirupp.controllers.Runner
  pybind11::object fault_class_;  // sirupp.controllers.ControllerFault
  pybind11::object fault_text_;   // sirupp.controllers.fault_text
};

}  // namespace sirupp::python
