#pragma once
// The parts of the extension module sirupp._sirupp (python/module.cpp), one function per file,
// and the exceptions they raise (registered as sirupp.ModelError, sirupp.IKError,
// sirupp.RigError: ValueError, ValueError, RuntimeError).

#include <pybind11/pybind11.h>

#include <memory>
#include <stdexcept>

namespace sirupp::core {
struct RobotModel;
}

namespace sirupp::python {

namespace py = pybind11;

// A model file that cannot be used: what() is the CLI's "file:line:col: key.path: problem".
class ModelError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};
// No joint vector reaches the pose: what() is the solver's reason, as `sirupp ik` prints it.
class IkError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};
// The rig refused a command, did not answer, or a move ended otherwise than done.
class RigError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

void BindModel(py::module_& m);              // bind_model.cpp
void BindRig(py::module_& m);                // bind_rig.cpp: client, recorder, local processes
void BindProcessController(py::module_& m);  // bind_process_controller.cpp
void BindData(py::module_& m);               // bind_data.cpp: the logger's data file reader
void BindPlanning(py::module_& m);           // bind_planning.cpp: sirupp.Scene, paths as plan text

// The model of a sirupp.Model object (bind_model.cpp), or nullptr when `value` is not one.
std::shared_ptr<const core::RobotModel> ModelOf(const py::handle& value);

}  // namespace sirupp::python
